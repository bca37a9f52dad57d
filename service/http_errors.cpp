#include "service/http_errors.h"

#include <nlohmann/json.hpp>

namespace rgbdcast::service {

int http_status_for(ErrorCode code) {
  switch (code) {
    case ErrorCode::kNotFound:
      return 404;
    case ErrorCode::kInvalidArgument:
      return 400;
    case ErrorCode::kInvalidInput:
      return 422;
    case ErrorCode::kEmpty:
      return 422;
    case ErrorCode::kUnavailable:
      return 503;
    case ErrorCode::kIo:
      return 500;
    case ErrorCode::kInternal:
      return 500;
  }
  return 500;
}

const char* error_name_for(int status) {
  switch (status) {
    case 400:
      return "bad_request";
    case 401:
      return "unauthorized";
    case 403:
      return "forbidden";
    case 404:
      return "not_found";
    case 405:
      return "method_not_allowed";
    case 408:
      return "request_timeout";
    case 409:
      return "conflict";
    case 411:
      return "length_required";
    case 413:
      return "payload_too_large";
    case 414:
      return "uri_too_long";
    case 415:
      return "unsupported_media_type";
    case 416:
      return "range_not_satisfiable";
    case 422:
      return "unprocessable_entity";
    case 431:
      return "request_header_fields_too_large";
    case 501:
      return "not_implemented";
    case 500:
      return "internal_error";
    case 503:
      return "unavailable";
    default:
      return status >= 500 ? "server_error" : "client_error";
  }
}

std::string error_body(int status, const std::string& detail) {
  // Replacement on invalid UTF-8: a detail may quote what a client sent.
  nlohmann::ordered_json body;  // "error" first, for people reading it
  body["error"] = error_name_for(status);
  body["detail"] = detail;
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace rgbdcast::service

namespace rgbdcast::service {

std::string redact_paths(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  size_t i = 0;
  while (i < text.size()) {
    const bool word_start = i == 0 || text[i - 1] == ' ' || text[i - 1] == '\'' || text[i - 1] == '"' ||
                            text[i - 1] == '(' || text[i - 1] == '=' || text[i - 1] == '\t';
    if (text[i] == '/' && word_start) {
      size_t end = i;
      while (end < text.size() && text[end] != ' ' && text[end] != '\'' && text[end] != '"' && text[end] != ')' &&
             text[end] != ',' && text[end] != ':' && text[end] != '\t' && text[end] != '\n')
        ++end;
      const std::string word = text.substr(i, end - i);
      if (word.find('/', 1) != std::string::npos) {
        out += "<path>";
        i = end;
        continue;
      }
    }
    out.push_back(text[i++]);
  }
  return out;
}

}  // namespace rgbdcast::service

namespace rgbdcast::service {}  // namespace rgbdcast::service
