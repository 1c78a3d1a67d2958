#pragma once
// The one exception type: a message that names the file (or option) and the problem.
#include <stdexcept>
#include <string>

namespace splitray {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
  Error(const std::string& where, const std::string& problem)
      : std::runtime_error(where + ": " + problem) {}
};

}  // namespace splitray
