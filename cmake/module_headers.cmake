# Include roots that make the layers a build rule (the design is explained in the top CMakeLists.txt).
#
# rgbdcast_module_headers(<target> [HEADERS h...] [PRIVATE_HEADERS h...])
#   Exposes the headers of the module folder that defines <target> (the current source folder) as "<module>/h".
#   Public headers: HEADERS when given (a folder that holds several libraries names each one's own), otherwise every
#   *.h directly in the folder except PRIVATE_HEADERS. Headers in subfolders are private.
#   - PUBLIC (INTERFACE for an INTERFACE library): include/<target>/, which holds <module>/ with links to the public
#     headers only;
#   - PRIVATE: include-private/<module>/, whose <module> links to the whole folder, for the module's own sources.
# rgbdcast_private_headers(<consumer> <target>...)
#   Lets <consumer> (a white-box test or a benchmark) include the private headers of each <target>'s module.

set(RGBDCAST_INCLUDE_ROOT "${PROJECT_BINARY_DIR}/include")
set(RGBDCAST_PRIVATE_INCLUDE_ROOT "${PROJECT_BINARY_DIR}/include-private")

# Links are remade at every configure, so a removed or renamed header does not linger.
function(rgbdcast_link_path target_path link_path)
  get_filename_component(parent "${link_path}" DIRECTORY)
  file(MAKE_DIRECTORY "${parent}")
  file(CREATE_LINK "${target_path}" "${link_path}" SYMBOLIC)
endfunction()

function(rgbdcast_module_headers target)
  cmake_parse_arguments(A "" "" "HEADERS;PRIVATE_HEADERS" ${ARGN})
  file(RELATIVE_PATH module "${PROJECT_SOURCE_DIR}" "${CMAKE_CURRENT_SOURCE_DIR}")
  if(A_HEADERS)
    set(public ${A_HEADERS})
  else()
    file(GLOB public CONFIGURE_DEPENDS RELATIVE "${CMAKE_CURRENT_SOURCE_DIR}" "${CMAKE_CURRENT_SOURCE_DIR}/*.h")
    if(A_PRIVATE_HEADERS)
      list(REMOVE_ITEM public ${A_PRIVATE_HEADERS})
    endif()
  endif()
  set(public_root "${RGBDCAST_INCLUDE_ROOT}/${target}")
  file(REMOVE_RECURSE "${public_root}")
  file(MAKE_DIRECTORY "${public_root}/${module}")
  foreach(header ${public})
    if(NOT EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/${header}")
      message(FATAL_ERROR "${target}: public header ${module}/${header} does not exist")
    endif()
    rgbdcast_link_path("${CMAKE_CURRENT_SOURCE_DIR}/${header}" "${public_root}/${module}/${header}")
  endforeach()

  set(private_root "${RGBDCAST_PRIVATE_INCLUDE_ROOT}/${module}")
  # Remade when it names another folder (a build folder copied from another checkout), else kept as it is.
  set(linked "")
  if(IS_SYMLINK "${private_root}/${module}")
    file(READ_SYMLINK "${private_root}/${module}" linked)
  endif()
  if(NOT linked STREQUAL CMAKE_CURRENT_SOURCE_DIR)
    file(REMOVE "${private_root}/${module}")
    rgbdcast_link_path("${CMAKE_CURRENT_SOURCE_DIR}" "${private_root}/${module}")
  endif()
  set_property(TARGET ${target} PROPERTY RGBDCAST_PRIVATE_INCLUDE "${private_root}")

  get_target_property(type ${target} TYPE)
  if(type STREQUAL "EXECUTABLE")
    target_include_directories(${target} BEFORE PRIVATE "${private_root}")
  elseif(type STREQUAL "INTERFACE_LIBRARY")
    target_include_directories(${target} INTERFACE "${public_root}")
  else()
    # The module's own folder first, so its sources never reach their own headers through another root.
    target_include_directories(${target} BEFORE PRIVATE "${private_root}")
    target_include_directories(${target} PUBLIC "${public_root}")
  endif()
endfunction()

function(rgbdcast_private_headers consumer)
  foreach(target ${ARGN})
    get_target_property(root ${target} RGBDCAST_PRIVATE_INCLUDE)
    if(NOT root)
      message(FATAL_ERROR "${consumer}: ${target} has no module headers (rgbdcast_module_headers)")
    endif()
    target_include_directories(${consumer} PRIVATE "${root}")
  endforeach()
endfunction()
