#pragma once
// Names of typed tests' parameters for gtest (TYPED_TEST_SUITE's third argument): each type names itself in its
// static kName, so that a suite reads "Suite/Postgres.Case" rather than "Suite/1.Case".
#include <string>

namespace rgbdcast::test {

struct SelfNamedTypes {
  template <class T>
  static std::string GetName(int) {
    return T::kName;
  }
};

}  // namespace rgbdcast::test
