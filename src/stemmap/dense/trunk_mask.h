#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/dense/stereo.h"

namespace stemmap::dense {

// Optional learned trunk segmentation, a plug-in: stemmap never needs one. Given a BGR keyframe
// image, a model returns a CV_8U mask of the same size, 255 where a pixel shows a stem.
class TrunkMaskModel {
 public:
  virtual ~TrunkMaskModel() = default;
  virtual std::string Describe() const = 0;
  virtual cv::Mat Predict(const cv::Mat& bgr) = 0;
};

// A segmentation network run by OpenCV's dnn module on the CPU (ONNX file, or any network
// OpenCV reads). Input: 1x3xHxW, RGB, (value / 255 - mean) / std per channel. Output: 1xCxhxw
// scores; with C = 1 a trunk logit (sigmoid), with C > 1 class logits (softmax across channels)
// of which `trunk_channel` is the trunk. Scores are resized to the image and thresholded.
struct DnnMaskOptions {
  std::filesystem::path model;  // empty: no model
  int input_width = 640, input_height = 384;
  int trunk_channel = 1;
  double threshold = 0.5;
  std::vector<double> mean = {0.485, 0.456, 0.406};  // ImageNet statistics, RGB
  std::vector<double> std = {0.229, 0.224, 0.225};
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(DnnMaskOptions, model, input_width, input_height,
                                                trunk_channel, threshold, mean, std)

// Reads the model file; InputError if it is missing or OpenCV cannot read it.
std::unique_ptr<TrunkMaskModel> LoadDnnMaskModel(const DnnMaskOptions& options);
// The same around a network already built (tests, other loaders).
std::unique_ptr<TrunkMaskModel> MakeDnnMaskModel(const cv::dnn::Net& net,
                                                 const DnnMaskOptions& options,
                                                 const std::string& name);

// Marks each point seen from keyframe `world_from_cam` as on a trunk (1) or not (0) by where it
// projects in that keyframe's mask; points outside the image are not on a trunk.
void LabelTrunkPoints(const cv::Mat& mask, const PinholeCamera& camera,
                      const Rigid3d& world_from_cam, std::vector<CloudPoint>* points);

}  // namespace stemmap::dense
