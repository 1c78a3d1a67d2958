#pragma once
// The one exception type: a message that names the file (or option) and the problem.
#include <stdexcept>
#include <string>

namespace splitray {

// what() is a C string: a NUL byte quoted from a file (a JSON "\u0000") would cut the message
// short there, so NUL bytes are written as \u0000.
inline std::string printable_message(std::string message) {
  for (std::size_t at = message.find('\0'); at != std::string::npos;
       at = message.find('\0', at + 6))
    message.replace(at, 1, "\\u0000");
  return message;
}

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(printable_message(message)) {}
  Error(const std::string& where, const std::string& problem)
      : std::runtime_error(printable_message(where + ": " + problem)) {}
};

}  // namespace splitray
