// Errors a user can cause (a bad file, a model the data cannot support) travel as values.
//
// An `Error` names where the problem is, as precisely as is known:
//   file      the file the user gave (may be empty for text not read from a file)
//   line/col  1-based position in that file (0 = unknown)
//   path      a JSON path such as `drift.mff` or `parameters.tau_fv.lower` (may be empty)
//   expr_col  1-based column inside an expression string (0 = not an expression error)
// and says what is wrong in `message`. `ToString()` gives the form the command line prints:
//   `FILE[:LINE[:COL]]: [PATH[, column N]: ]message`.
//
// Programmer errors (wrong dimensions, broken invariants) are assertions, not Errors.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace gb {

// What kind of failure: the command line maps kInput to exit status 2, kNumerical to 1.
enum class ErrorKind { kInput, kNumerical };

struct Error {
  ErrorKind kind = ErrorKind::kInput;
  std::string file;
  int line = 0;
  int col = 0;
  std::string path;
  int expr_col = 0;
  std::string message;

  std::string ToString() const {
    std::string out = file;
    if (!file.empty() && line > 0) {
      out += ":" + std::to_string(line);
      if (col > 0) out += ":" + std::to_string(col);
    }
    std::string where = path;
    if (expr_col > 0) where += (where.empty() ? "column " : ", column ") + std::to_string(expr_col);
    if (!where.empty()) out += (out.empty() ? "" : ": ") + where;
    out += (out.empty() ? "" : ": ") + message;
    return out;
  }
};

inline Error InputError(std::string message) {
  Error e;
  e.message = std::move(message);
  return e;
}

inline Error NumericalError(std::string message) {
  Error e;
  e.kind = ErrorKind::kNumerical;
  e.message = std::move(message);
  return e;
}

// A value or an Error. Deliberately small: `ok()`, `value()`, `error()`, and `*`/`->`.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : v_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(v_); }
  explicit operator bool() const { return ok(); }

  const T& value() const& {
    assert(ok() && "Result::value() on an error");
    return std::get<T>(v_);
  }
  T& value() & {
    assert(ok() && "Result::value() on an error");
    return std::get<T>(v_);
  }
  T&& value() && {
    assert(ok() && "Result::value() on an error");
    return std::get<T>(std::move(v_));
  }
  const Error& error() const {
    assert(!ok() && "Result::error() on a value");
    return std::get<Error>(v_);
  }

  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  std::variant<T, Error> v_;
};

// For functions that return nothing but may fail.
struct Ok {};
using Status = Result<Ok>;

}  // namespace gb
