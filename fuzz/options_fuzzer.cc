// Options files (track --options, process --options: a run's process_options.json).
#include "fuzz_file.h"
#include "stemmap/core/io.h"
#include "stemmap/pipeline/process.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = stemmap::fuzz::WriteInput("options.json", stemmap::fuzz::AsText(data, size));
  return stemmap::fuzz::Parse(
      [&] { stemmap::ReadOptionsJson<stemmap::pipeline::ProcessOptions>(path); });
}
