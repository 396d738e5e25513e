# The build enforces the module table of docs/development.md: a target sees the headers of the
# targets it links, and no others.
#
# Sources include headers by their path from the source root ("common/util/status.h"), so
# the root itself can never be an include directory: it would expose every header to every
# target. Instead each module gets an include tree of its own under the build directory,
# holding symbolic links to its headers at those same paths:
#
#   build/include/sceneloc_util/common/util/status.h -> <source>/common/util/status.h
#
# A target's tree is PUBLIC (INTERFACE for header-only modules, PRIVATE for executables), so
# it reaches exactly the targets that link the module, transitively only through PUBLIC
# links. Including a header of a module one does not link fails with "No such file or
# directory" (ctest build/LayeringIsEnforced shows it).

# sceneloc_module_headers(TARGET [HEADERS h1.h h2.h ...])
#   Exposes HEADERS (default: every *.h in the calling folder) as TARGET's own include tree.
function(sceneloc_module_headers target)
  cmake_parse_arguments(ARG "" "" "HEADERS" ${ARGN})
  if(ARG_HEADERS)
    set(headers ${ARG_HEADERS})
  else()
    file(GLOB headers CONFIGURE_DEPENDS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
         ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  endif()
  file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  set(tree ${PROJECT_BINARY_DIR}/include/${target})
  # Rebuilt on every configure, so a removed or moved header never lingers in a tree.
  file(REMOVE_RECURSE ${tree})
  file(MAKE_DIRECTORY ${tree}/${folder})
  foreach(header ${headers})
    set(source ${CMAKE_CURRENT_SOURCE_DIR}/${header})
    if(NOT EXISTS ${source})
      message(FATAL_ERROR "sceneloc_module_headers(${target}): no header ${folder}/${header}")
    endif()
    get_filename_component(subfolder ${header} DIRECTORY)
    file(MAKE_DIRECTORY ${tree}/${folder}/${subfolder})
    file(CREATE_LINK ${source} ${tree}/${folder}/${header} SYMBOLIC)
  endforeach()

  get_target_property(type ${target} TYPE)
  if(type STREQUAL "EXECUTABLE")
    target_include_directories(${target} PRIVATE ${tree})
  elseif(type STREQUAL "INTERFACE_LIBRARY")
    target_include_directories(${target} INTERFACE ${tree})
  else()
    target_include_directories(${target} PUBLIC ${tree})
  endif()
endfunction()
