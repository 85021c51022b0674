// Tree lists (evaluate --pred, trees.csv or any CSV with x, y and DBH columns).
#include "fuzz_file.h"
#include "stemmap/eval/plot_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("trees.csv", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse([&] { stemmap::eval::ReadTreesCsv(path); });
}
