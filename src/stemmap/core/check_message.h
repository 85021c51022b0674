#pragma once

#include <string>

#include "stemmap/core/error.h"

namespace stemmap {

// The message an options struct's Check() gives, or "" when the options pass (for tests).
template <typename Options>
std::string CheckMessage(const Options& o) {
  try {
    o.Check();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The InputError message `f` throws, or "" when it throws none (for tests).
template <typename F>
std::string InputErrorMessage(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace stemmap
