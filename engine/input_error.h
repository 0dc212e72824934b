#pragma once
// The one exception type for bad input: it names the file, line, column and field, and what would
// be valid. Thrown only at load time, never inside a step.
#include <sstream>
#include <stdexcept>
#include <string>

namespace dem {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, int line, int column, std::string field, const std::string& message)
      : std::runtime_error(format(file, line, column, field, message)),
        file_(std::move(file)),
        line_(line),
        column_(column),
        field_(std::move(field)) {}

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }
  const std::string& field() const { return field_; }

 private:
  static std::string format(const std::string& file, int line, int column, const std::string& field,
                            const std::string& message) {
    std::ostringstream s;  // (string operator+ chains trip a false -Wrestrict in g++ 12)
    s << file;
    if (line > 0) s << ':' << line;
    if (column > 0) s << ':' << column;
    s << ": ";
    if (!field.empty()) s << '\'' << field << "': ";
    s << message;
    return s.str();
  }

  std::string file_;
  int line_;
  int column_;
  std::string field_;
};

}  // namespace dem
