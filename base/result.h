#pragma once
// Errors as values (after vk-bootstrap's Result<T>): a failing stage returns an Error with a typed code and a
// one-line message; the CLI prints it, the HTTP layer maps the code to a status. No exception crosses a module edge.
#include <string>
#include <utility>
#include <variant>

namespace rgbdcast {

enum class ErrorCode {
  kNotFound,         // a file, frame or scene that does not exist
  kInvalidInput,     // malformed data: corrupt image, truncated GLB, wrong size or bit depth
  kInvalidArgument,  // a parameter out of range: negative voxel size, NaN in a pose, absurd image size
  kEmpty,            // nothing to work on: no valid depth, an empty scene
  kUnavailable,      // a backend or device that cannot be used on this machine
  kIo,               // a read or write that failed for reasons outside the data
  kInternal,
};

const char* to_string(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string message;  // one line, names the problem and the thing it concerns
};

inline Error make_error(ErrorCode code, std::string message) { return Error{code, std::move(message)}; }

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : v_(std::move(error)) {}  // NOLINT
  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() & { return std::get<0>(v_); }
  const T& value() const& { return std::get<0>(v_); }
  T&& value() && { return std::get<0>(std::move(v_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  const Error& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

// Result<void>: success or an Error.
struct Ok {};
using Status = Result<Ok>;
inline Status ok_status() { return Ok{}; }

}  // namespace rgbdcast
