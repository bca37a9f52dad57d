#pragma once
// Raw HTTP/1.1 over a loopback TCP socket, for requests a client library would not send (lying Content-Length,
// broken chunked framing, slow or idle connections). Test helper.
#include <map>
#include <string>

namespace rgbdcast::test {

struct RawResponse {
  bool ok = false;  // a status line was received
  int status = 0;
  std::map<std::string, std::string> headers;  // names lower case
  std::string body;
  double ms = 0.0;  // from connect to the end of the response
};

int connect_loopback(int port, const char* address = "127.0.0.1");
bool send_all(int fd, const std::string& bytes);  // false when the peer closed or reset
// Sends `request` (stops sending if the server closes) and reads one response, within timeout_s.
RawResponse raw_request(int port, const std::string& request, double timeout_s = 10.0);
// The bytes a gzip body (Content-Encoding: gzip) holds, or "" when it is not one whole gzip stream.
std::string gunzip(const std::string& in);
// Reads one response from a connected socket within timeout_s.
RawResponse read_response(int fd, double timeout_s);
// Opens an event stream (GET path, Accept: text/event-stream) and reads until `needle` arrived, the server closed or
// timeout_s passed; returns the raw bytes that arrived (status line and headers included).
std::string read_event_stream_until(int port, const std::string& path, const std::string& needle, double timeout_s);

}  // namespace rgbdcast::test
