# Instrumented builds, each in its own build folder (scripts/fuzz.sh, scripts/sanitize.sh):
# - RGBDCAST_SANITIZE=ON (build-asan/): every target with AddressSanitizer + UndefinedBehaviorSanitizer, so the
#   GoogleTest suite runs sanitized. Any error aborts the test (no recovery).
# - RGBDCAST_FUZZ=ON (build-fuzz/, clang only): the same, plus libFuzzer coverage, and the harnesses in fuzz/.
# System libraries (OpenCV, PCL, tinygltf, libpng) are not instrumented: ASan sees their heap through its
# interceptors only, and coverage stops at their edge.
option(RGBDCAST_SANITIZE "Build with ASan + UBSan" OFF)
option(RGBDCAST_FUZZ "Build the libFuzzer harnesses (fuzz/) with ASan + UBSan; needs clang" OFF)
if(RGBDCAST_SANITIZE OR RGBDCAST_FUZZ)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
  if(RGBDCAST_FUZZ)
    # The libFuzzer build (CI's fuzz smoke run and its sanitized tests) compiles as OSS-Fuzz does, at -O1 with line
    # tables only: a report's stack still names file and line, and the build takes less time than at -O2 -g.
    add_compile_options(-O1 -gline-tables-only)
  else()
    add_compile_options(-g)
  endif()
  add_link_options(-fsanitize=address,undefined)
  # Eigen uses glibc's malloc for aligned storage, except when it sees __SANITIZE_ADDRESS__: then its own
  # over-allocating "handmade" aligned malloc, whose free reads a header before the block. PCL's libraries are built
  # without ASan (plain malloc), so a vector PCL allocates and our inlined destructor frees (GreedyProjection-
  # Triangulation's) was freed the handmade way: ASan heap-buffer-overflow 8 bytes before the block
  # (openmp_threads_test, paper preset). Keep Eigen's allocator ABI the same as the uninstrumented libraries'.
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
endif()
if(RGBDCAST_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "RGBDCAST_FUZZ needs clang (CXX=clang++-16 CC=clang-16)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
