// Camera calibrations (--calibration, OpenCV YAML).
#include "fuzz_file.h"
#include "stemmap/calib/calibrate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("phone.yaml", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse([&] { stemmap::calib::ReadCalibration(path, 1920, 1080); });
}
