// The translation unit that compiles the test programs' precompiled header (rgbdcast_test_pch, tests/CMakeLists.txt).
