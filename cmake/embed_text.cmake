# cmake -DINPUT=file -DOUTPUT=header.h -DNAME=symbol -P embed_text.cmake
# Writes the text of INPUT as a C++ raw string constant NAME (the OpenGL backend compiles GLSL from text).
file(READ "${INPUT}" content)
set(delim "rgbdcast_glsl")
file(WRITE "${OUTPUT}.tmp" "#pragma once\n// Generated from ${INPUT}; do not edit.\ninline constexpr char ${NAME}[] = R\"${delim}(${content})${delim}\";\n")
file(RENAME "${OUTPUT}.tmp" "${OUTPUT}")
