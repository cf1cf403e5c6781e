# Included after project() (CMAKE_PROJECT_INCLUDE). The ROS 2 Jazzy wheels export imported
# targets whose INTERFACE_INCLUDE_DIRECTORIES name folders of the machine the wheels were built
# on (under /opt/python/...); CMake's generate step stops on include folders that do not exist.
# At the end of the top-level CMakeLists, once every find_package has run, each imported
# target's include folders are reduced to the ones that exist here.
function(strip_foreign_include_dirs)
  get_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs)
      continue()
    endif()
    set(kept "")
    foreach(dir IN LISTS dirs)
      if(dir MATCHES "^\\$<" OR EXISTS "${dir}")
        list(APPEND kept "${dir}")
      else()
        message(VERBOSE "${target}: dropped the missing include folder ${dir}")
      endif()
    endforeach()
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${kept}")
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL strip_foreign_include_dirs)
