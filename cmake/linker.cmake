# The linker. Most programs link PCL, which brings in VTK's shared libraries (dozens, with large symbol tables):
# GNU ld (bfd) takes about 8 s to link one test program against them, gold well under 1 s, for the same program
# (BENCHMARKS.md, "Time of the test command"). gold is part of binutils, which every Debian C++ toolchain has.
# The sanitized builds (cmake/sanitizers.cmake) keep the compiler's default: gold warns about every local symbol of
# clang's ASan runtime ("Cannot export local symbol"), and those builds link few programs.
# RGBDCAST_LINKER: the name given to -fuse-ld= (empty: the compiler's default). A linker the compiler cannot use is
# reported and left out.
include(CheckLinkerFlag)
if(RGBDCAST_SANITIZE OR RGBDCAST_FUZZ)
  set(default_linker "")
else()
  set(default_linker "gold")
endif()
set(RGBDCAST_LINKER "${default_linker}" CACHE STRING "Linker (-fuse-ld=NAME); empty for the compiler's default")
if(RGBDCAST_LINKER)
  check_linker_flag(CXX "-fuse-ld=${RGBDCAST_LINKER}" RGBDCAST_LINKER_USABLE)
  if(RGBDCAST_LINKER_USABLE)
    add_link_options("-fuse-ld=${RGBDCAST_LINKER}")
  else()
    message(STATUS "rgbdcast: -fuse-ld=${RGBDCAST_LINKER} does not work with ${CMAKE_CXX_COMPILER}; using its default linker")
  endif()
endif()
