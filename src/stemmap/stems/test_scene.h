#pragma once

// Test scenes for the silhouette and bark estimators: keyframes on the arm's circle looking
// outward at vertical stems, rendered by ray casting.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"

namespace stemmap::stems {

struct RenderedStem {
  PinholeCamera camera = PinholeCamera::FromHfov(640, 360, 67.0);
  std::vector<StampedPose> keyframes;
  std::vector<cv::Mat> gray;
};

// Textures: regular (bark furrows a stripe every 9° of the stem's azimuth, a textured background
// a stripe every 0.9°), irregular (bark and background value noise, nothing periodic), or plain
// bark (one grey) before the regular background, or irregular bark whose limbs are shaded (where
// the surface turns more than 50 degrees from the plot centre, 60 grey levels darker: shading
// symmetric about the line of sight, whose edges lie at a fixed share of the stem's apparent
// half-width in every view), or noisy bark: irregular bark at half its contrast beneath a new
// pattern of 2-pixel grains in each keyframe (furrows finer than a pixel, aliased differently in
// each view; leaf shadows moving across it), on which views correlate at about 0.2, before the
// irregular background.
enum class Texture { kRegular, kIrregular, kPlainBark, kLimbShaded, kNoisyBark };

// A sapling's leaf clump: an ellipsoid (centre and semi-axes, plot frame, m) of leaves a few
// centimetres across with leaf-sized holes, denser towards its centre (density: about the share
// of its volume that is leaves), as the simulator's saplings carry.
struct LeafClump {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d radii_m = Eigen::Vector3d::Constant(0.4);
  double density = 0.4;
};

// How far along the ray from `origin` in the unit direction `dir` it meets the clump's first
// leaf, or -1 where it passes through.
double HitLeafClump(const LeafClump& clump, const Eigen::Vector3d& origin,
                    const Eigen::Vector3d& dir);

// Stems as (x, y, radius); the nearest one a pixel's ray meets is seen, each with its own bark,
// in front of either a plain sky or a textured far background. With `sunlit`, sun from +y lights
// the stems' left sides (as seen looking along +x) brighter than a plain grey sky, their middles
// darker.
// `camera`: the images' (the 640-px default is quick to render; the pipeline's working images are
// 960 px wide, the size the silhouette options are set for).
// `clumps`: leaf clumps, seen where they lie nearer than the stems, dark green leaves of varying
// shade.
// `sky_luma`: the plain sky's grey level where it is not the default (130 sunlit, 210 otherwise),
// e.g. a hazy sky as bright as a sunlit side.
RenderedStem RenderStems(const std::vector<Eigen::Vector3d>& stems, bool textured_background,
                         bool sunlit = false, Texture texture = Texture::kRegular,
                         const PinholeCamera& camera = PinholeCamera::FromHfov(640, 360, 67.0),
                         const std::vector<LeafClump>& clumps = {}, double sky_luma = -1.0);

}  // namespace stemmap::stems
