#include "stemmap/dense/trunk_mask.h"

#include <fmt/format.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "stemmap/core/error.h"

namespace stemmap::dense {

void DnnMaskOptions::Check() const {
  if (input_width < 16 || input_height < 16 || input_width > 4096 || input_height > 4096) {
    throw InputError(
        fmt::format("mask model input {}x{}: use 16 to 4096 pixels", input_width, input_height));
  }
  if (trunk_channel < 0) throw InputError("mask model trunk channel must be >= 0");
  if (!(threshold > 0 && threshold < 1)) throw InputError("mask threshold must be in (0, 1)");
  if (mean.size() != 3 || std.size() != 3) {
    throw InputError("mask model mean and std need three values (R, G, B)");
  }
  for (double s : std) {
    if (!(s > 0)) throw InputError("mask model std values must be positive");
  }
}

namespace {

class DnnMaskModel : public TrunkMaskModel {
 public:
  DnnMaskModel(const cv::dnn::Net& net, const DnnMaskOptions& o, std::string name)
      : net_(net), options_(o), name_(std::move(name)) {
    net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  }

  std::string Describe() const override {
    return fmt::format("{} ({}x{} input)", name_, options_.input_width, options_.input_height);
  }

  cv::Mat Predict(const cv::Mat& bgr) override {
    if (bgr.empty() || bgr.type() != CV_8UC3) throw InputError("mask model needs a BGR image");
    const DnnMaskOptions& o = options_;
    cv::Mat rgb;
    cv::resize(bgr, rgb, cv::Size(o.input_width, o.input_height), 0, 0, cv::INTER_AREA);
    cv::cvtColor(rgb, rgb, cv::COLOR_BGR2RGB);
    rgb.convertTo(rgb, CV_32FC3, 1.0 / 255.0);
    rgb -= cv::Scalar(o.mean[0], o.mean[1], o.mean[2]);
    cv::divide(rgb, cv::Scalar(o.std[0], o.std[1], o.std[2]), rgb);
    net_.setInput(cv::dnn::blobFromImage(rgb));
    cv::Mat out;
    try {
      out = net_.forward();
    } catch (const cv::Exception& e) {
      throw ProcessingError(fmt::format("mask model {} failed: {}", name_, e.msg));
    }
    if (out.dims != 4 || out.size[0] != 1) {
      throw ProcessingError(fmt::format("mask model {}: output must be 1xCxHxW", name_));
    }
    const int c = out.size[1], h = out.size[2], w = out.size[3];
    if (c > 1 && o.trunk_channel >= c) {
      throw InputError(fmt::format("mask model {} has {} output channels; no channel {}", name_, c,
                                   o.trunk_channel));
    }
    auto plane = [&](int k) { return cv::Mat(h, w, CV_32F, out.ptr<float>(0, k)); };
    cv::Mat prob(h, w, CV_32F);
    if (c == 1) {
      cv::Mat e;
      cv::exp(-plane(0), e);
      prob = 1.0 / (1.0 + e);
    } else {
      // Softmax of the trunk channel, shifted by the per-pixel maximum for stability.
      cv::Mat top = plane(0).clone();
      for (int k = 1; k < c; ++k) top = cv::max(top, plane(k));
      cv::Mat sum = cv::Mat::zeros(h, w, CV_32F), e;
      for (int k = 0; k < c; ++k) {
        cv::exp(plane(k) - top, e);
        sum += e;
      }
      cv::exp(plane(o.trunk_channel) - top, e);
      prob = e / sum;
    }
    cv::Mat full, mask;
    cv::resize(prob, full, bgr.size(), 0, 0, cv::INTER_LINEAR);
    cv::compare(full, o.threshold, mask, cv::CMP_GT);
    return mask;
  }

 private:
  cv::dnn::Net net_;
  DnnMaskOptions options_;
  std::string name_;
};

}  // namespace

std::unique_ptr<TrunkMaskModel> MakeDnnMaskModel(const cv::dnn::Net& net,
                                                 const DnnMaskOptions& options,
                                                 const std::string& name) {
  options.Check();
  return std::make_unique<DnnMaskModel>(net, options, name);
}

std::unique_ptr<TrunkMaskModel> LoadDnnMaskModel(const DnnMaskOptions& options) {
  options.Check();
  const std::string path = options.model.string();
  if (!std::filesystem::is_regular_file(options.model)) {
    throw InputError(fmt::format("mask model {}: no such file", path));
  }
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNet(path);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("mask model {}: OpenCV cannot read it ({})", path, e.err));
  }
  if (net.empty()) throw InputError(fmt::format("mask model {}: OpenCV cannot read it", path));
  return MakeDnnMaskModel(net, options, options.model.filename().string());
}

void LabelTrunkPoints(const cv::Mat& mask, const PinholeCamera& camera,
                      const Rigid3d& world_from_cam, std::vector<CloudPoint>* points) {
  if (mask.type() != CV_8U) throw ProcessingError("trunk mask must be 8-bit, one channel");
  const double sx = static_cast<double>(mask.cols) / camera.width;
  const double sy = static_cast<double>(mask.rows) / camera.height;
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  for (CloudPoint& p : *points) {
    const Eigen::Vector3d p_cam = cam_from_world * p.world.cast<double>();
    p.trunk = 0;
    if (p_cam.z() <= 0) continue;
    const Eigen::Vector2d px = camera.ImageFromCam(p_cam);
    const int u = static_cast<int>(std::lround(px.x() * sx));
    const int v = static_cast<int>(std::lround(px.y() * sy));
    if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows) continue;
    p.trunk = mask.at<uint8_t>(v, u) > 127 ? 1 : 0;
  }
}

}  // namespace stemmap::dense
