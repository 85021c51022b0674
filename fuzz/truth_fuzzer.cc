// A plot's truth (evaluate --truth, truth.json).
#include "fuzz_file.h"
#include "stemmap/eval/plot_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("truth.json", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse([&] { stemmap::eval::ReadTruthJson(path); });
}
