# Included right after project() (CMAKE_PROJECT_INCLUDE) when an interface package of interfaces/ is
# built by pip (its pyproject.toml names this file relative to its own folder).
#
# 1. The ROS wheels install ament packages into Python environment prefixes: the build's isolated
#    environment (the rosidl toolchain) and the target environment (geometry_msgs, the rosidl
#    runtime). CMake and ament look for packages in every such prefix.
# 2. The wheels' exported CMake targets still name include directories of the container the wheels
#    were built in (/opt/python/cp311-cp311/...); CMake's generate step refuses non-existent
#    include directories, so they are dropped once every package is found.

find_package(Python3 REQUIRED COMPONENTS Interpreter)

execute_process(
  COMMAND "${Python3_EXECUTABLE}" -c [=[
import os, sys
prefixes = [sys.prefix]
for entry in sys.path:
    parts = os.path.normpath(entry).split(os.sep)
    # <prefix>/lib/pythonX.Y/site-packages -> <prefix>
    if len(parts) > 3 and parts[-1] == "site-packages" and parts[-3] == "lib":
        prefix = os.sep.join(parts[:-3])
        if os.path.isdir(os.path.join(prefix, "share", "ament_index")) and prefix not in prefixes:
            prefixes.insert(0, prefix)
print(";".join(prefixes), end="")
]=]
  OUTPUT_VARIABLE _pip_ament_prefixes
  RESULT_VARIABLE _pip_result
)
if(NOT _pip_result EQUAL 0)
  message(FATAL_ERROR "could not list the Python environment prefixes with ${Python3_EXECUTABLE}")
endif()
message(STATUS "ament prefixes of the Python environments: ${_pip_ament_prefixes}")
# The target environment: the only prefix that outlives the build (CMakeLists.txt uses it).
list(GET _pip_ament_prefixes -1 PIP_TARGET_PREFIX)
list(PREPEND CMAKE_PREFIX_PATH ${_pip_ament_prefixes})
string(REPLACE ";" ":" _pip_ament_env "${_pip_ament_prefixes}")
set(ENV{AMENT_PREFIX_PATH} "${_pip_ament_env}")
set(ENV{CMAKE_PREFIX_PATH} "${_pip_ament_env}")

function(_pip_drop_missing_include_dirs)
  get_property(_targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(_target IN LISTS _targets)
    get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT _dirs)
      continue()
    endif()
    set(_kept "")
    foreach(_dir IN LISTS _dirs)
      if(_dir MATCHES "^\\$<" OR EXISTS "${_dir}")
        list(APPEND _kept "${_dir}")
      endif()
    endforeach()
    set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
  endforeach()
endfunction()
cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _pip_drop_missing_include_dirs)
