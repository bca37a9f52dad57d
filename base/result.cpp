#include "base/result.h"

namespace rgbdcast {

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::kNotFound:
      return "not found";
    case ErrorCode::kInvalidInput:
      return "invalid input";
    case ErrorCode::kInvalidArgument:
      return "invalid argument";
    case ErrorCode::kEmpty:
      return "empty";
    case ErrorCode::kUnavailable:
      return "unavailable";
    case ErrorCode::kIo:
      return "i/o error";
    case ErrorCode::kInternal:
      return "internal error";
  }
  return "error";
}

}  // namespace rgbdcast
