#include "stemmap/cli/commands.h"

namespace stemmap::cli {

void AddEvaluateCommand(CLI::App&) {}

}  // namespace stemmap::cli
