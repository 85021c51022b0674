#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/sim/rig.h"
#include "stemmap/sim/scene.h"

namespace stemmap::sim {

// Writes truth.json: intrinsics, rig, every tree's position and DBH at breast height, saplings
// apart, and the pose of every frame. Format in docs/output-format.md.
// `frames` are in the capture's plot frame; the scene is in the stand's, where the plot frame
// stands at `stand_from_plot`. Trees, sun and poses are written in the plot frame.
// `camera_extra` (an object) is merged into the intrinsics: the phone's effects, where any.
void WriteTruth(const std::filesystem::path& path, const Scene& scene, const PinholeCamera& camera,
                const RigParams& rig, const std::vector<RigFrame>& frames, uint64_t seed,
                const Rigid3d& stand_from_plot = {},
                const nlohmann::json& camera_extra = nlohmann::json::object());

// Writes frames_truth.csv: each frame's intrinsics where they change from frame to frame (focus
// breathing, a stabilising crop), with the autofocus distance where it drives them (`focus_m`
// empty: no column).
void WriteFramesTruth(const std::filesystem::path& path, const std::vector<RigFrame>& frames,
                      const std::vector<PinholeCamera>& cameras,
                      const std::vector<double>& focus_m);

}  // namespace stemmap::sim
