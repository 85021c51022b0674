#pragma once

#include <stdexcept>
#include <string>

namespace stemmap {

// Thrown for bad user input (flags, files, videos). main() prints what() on one line and exits 2.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

// Thrown when a stage cannot produce a trustworthy result from valid input. Exit code 3.
class ProcessingError : public std::runtime_error {
 public:
  explicit ProcessingError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace stemmap
