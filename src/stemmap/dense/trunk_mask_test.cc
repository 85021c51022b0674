#include "stemmap/dense/trunk_mask.h"

#include <gtest/gtest.h>

#include <fstream>

#include "stemmap/core/error.h"

namespace stemmap::dense {
namespace {

// A one-layer network: 1x1 convolution of the normalised RGB input with `weights` (one row of
// three per output channel), no bias.
cv::dnn::Net PointwiseNet(const std::vector<std::array<float, 3>>& weights) {
  const int sizes[] = {static_cast<int>(weights.size()), 3, 1, 1};
  cv::Mat w(4, sizes, CV_32F);
  for (size_t k = 0; k < weights.size(); ++k) {
    for (int c = 0; c < 3; ++c) w.ptr<float>(static_cast<int>(k), c)[0] = weights[k][c];
  }
  cv::dnn::LayerParams lp;
  lp.name = "pointwise";
  lp.type = "Convolution";
  lp.set("kernel_size", 1);
  lp.set("num_output", static_cast<int>(weights.size()));
  lp.set("bias_term", false);
  lp.blobs.push_back(w);
  cv::dnn::Net net;
  net.addLayerToPrev(lp.name, lp.type, lp);
  return net;
}

// Left half red bark, right half blue sky.
cv::Mat RedLeftBlueRight() {
  cv::Mat bgr(90, 160, CV_8UC3, cv::Scalar(230, 40, 30));
  bgr(cv::Rect(0, 0, 80, 90)).setTo(cv::Scalar(30, 40, 230));
  return bgr;
}

DnnMaskOptions PlainInput() {
  DnnMaskOptions o;
  o.input_width = 64;
  o.input_height = 36;
  o.mean = {0, 0, 0};
  o.std = {1, 1, 1};
  return o;
}

TEST(TrunkMask, ClassLogitsGiveTheTrunkChannel) {
  // Channel 0 "background" = 10 (B - R), channel 1 "trunk" = 10 (R - B), in RGB input order.
  auto model = MakeDnnMaskModel(PointwiseNet({{-10, 0, 10}, {10, 0, -10}}), PlainInput(), "test");
  const cv::Mat mask = model->Predict(RedLeftBlueRight());
  ASSERT_EQ(mask.size(), cv::Size(160, 90));
  ASSERT_EQ(mask.type(), CV_8U);
  EXPECT_EQ(mask.at<uint8_t>(45, 20), 255);
  EXPECT_EQ(mask.at<uint8_t>(45, 140), 0);
  EXPECT_NEAR(cv::countNonZero(mask) / (160.0 * 90.0), 0.5, 0.03);
}

TEST(TrunkMask, SingleLogitUsesASigmoid) {
  DnnMaskOptions o = PlainInput();
  o.trunk_channel = 0;
  auto model = MakeDnnMaskModel(PointwiseNet({{-10, 0, 10}}), o, "test");  // trunk = blue here
  const cv::Mat mask = model->Predict(RedLeftBlueRight());
  EXPECT_EQ(mask.at<uint8_t>(45, 20), 0);
  EXPECT_EQ(mask.at<uint8_t>(45, 140), 255);
}

TEST(TrunkMask, BadModelsAndOptionsAreInputErrors) {
  DnnMaskOptions o = PlainInput();
  o.trunk_channel = 5;
  auto model = MakeDnnMaskModel(PointwiseNet({{1, 0, 0}, {0, 1, 0}}), o, "test");
  EXPECT_THROW(model->Predict(RedLeftBlueRight()), InputError);

  // The one-line errors name the file and say what is wrong with it.
  auto load_error = [](const DnnMaskOptions& opt) -> std::string {
    try {
      LoadDnnMaskModel(opt);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  o = PlainInput();
  o.model = "/nonexistent/model.onnx";
  EXPECT_EQ(load_error(o), "mask model /nonexistent/model.onnx: no such file");
  const std::filesystem::path junk =
      std::filesystem::temp_directory_path() / "stemmap_trunk_mask_junk.onnx";
  std::ofstream(junk) << "not a network";
  o.model = junk;
  EXPECT_NE(load_error(o).find("OpenCV cannot read it"), std::string::npos);
  std::filesystem::remove(junk);

  o = PlainInput();
  o.threshold = 1.5;
  EXPECT_THROW(o.Check(), InputError);
  o = PlainInput();
  o.std = {1, 0, 1};
  EXPECT_THROW(o.Check(), InputError);
}

TEST(TrunkMask, PointsAreLabelledWhereTheyProject) {
  const PinholeCamera cam = PinholeCamera::FromHfov(160, 90, 60);
  cv::Mat mask(45, 80, CV_8U, cv::Scalar(0));  // a mask at half the camera's size
  mask(cv::Rect(0, 0, 40, 45)).setTo(255);     // left half is trunk
  const Rigid3d world_from_cam;                // identity: camera axes are world axes
  std::vector<CloudPoint> pts(3);
  pts[0].world = {-1.0f, 0.0f, 5.0f};  // left of centre
  pts[1].world = {1.0f, 0.0f, 5.0f};   // right
  pts[2].world = {0.0f, 0.0f, -5.0f};  // behind the camera
  LabelTrunkPoints(mask, cam, world_from_cam, &pts);
  EXPECT_EQ(pts[0].trunk, 1);
  EXPECT_EQ(pts[1].trunk, 0);
  EXPECT_EQ(pts[2].trunk, 0);
}

}  // namespace
}  // namespace stemmap::dense
