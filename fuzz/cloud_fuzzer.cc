// The fused cloud (cloud.ply, cloud_coarse.ply; stems --from).
#include "fuzz_file.h"
#include "stemmap/dense/cloud_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("cloud.ply", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse([&] { stemmap::dense::ReadCloudPly(path); });
}
