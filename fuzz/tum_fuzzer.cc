// Trajectories in TUM format (keyframes.tum, trajectory.tum; evaluate --trajectory).
#include "fuzz_file.h"
#include "stemmap/core/pose.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("poses.tum", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse([&] { stemmap::ReadTumTrajectory(path); });
}
