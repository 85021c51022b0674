// Stem maps for the simulator (simulate --layout, a field plot's CSV).
#include "fuzz_file.h"
#include "stemmap/sim/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("layout.csv", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse([&] {
    stemmap::sim::ReadLayoutCsv(path);
    stemmap::sim::ReadLayoutCsv(path, "3");
  });
}
