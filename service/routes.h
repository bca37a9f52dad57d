#pragma once
// The service's routes as one table, matched without regular expressions: the metrics label of a request and the
// methods its route allows are known before the request is read further (unknown method on a known route: 405 with
// Allow; unknown path: 404). Thread-safe (pure functions).
#include <string>
#include <string_view>

namespace rgbdcast::service {

struct RouteMatch {
  const char* label = "other";  // "/v1/scenes/{id}/view", ...; "other" when no route has this path
  const char* allow = "";       // the Allow header of the route ("GET, HEAD"); empty when no route matches
  bool known = false;
  bool allows(std::string_view method) const;
};

// `path` is the decoded path without the query (httplib's Request::path).
RouteMatch match_route(std::string_view path);

}  // namespace rgbdcast::service
