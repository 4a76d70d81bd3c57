# Keeps the sources of `target` that include ITK out of its unity batches
# (ITK 5.2 bundles its own Eigen, which clashes with the system Eigen in one
# translation unit).
function(mrsns_unity_exclusions target)
  get_target_property(_sources ${target} SOURCES)
  get_target_property(_dir ${target} SOURCE_DIR)
  foreach(_src IN LISTS _sources)
    if(NOT _src MATCHES "\\.cpp$")
      continue()
    endif()
    if(NOT IS_ABSOLUTE "${_src}")
      set(_src "${_dir}/${_src}")
    endif()
    file(STRINGS "${_src}" _itk REGEX "#include [<\"][^>\"]*itk")
    if(_itk)
      set_source_files_properties("${_src}" TARGET_DIRECTORY ${target} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
    endif()
  endforeach()
endfunction()

# The optimisation of a test program's own sources (MRSNS_TEST_OPTIMIZATION).
function(mrsns_test_flags target)
  if(NOT MRSNS_TEST_OPTIMIZATION OR NOT CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    return()
  endif()
  # After the build type's -O3: the last -O on the command line wins.
  target_compile_options(${target} PRIVATE ${MRSNS_TEST_OPTIMIZATION})
  # GCC 12 at -O1 reports Eigen's copy of a fully written dynamic matrix as
  # maybe-uninitialized (e.g. tests/core/test_point_locator.cpp, a 1x3
  # matrix filled with <<); the libraries keep the warning at -O3.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND MRSNS_TEST_OPTIMIZATION MATCHES "^-O[1g]$")
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
endfunction()

# The optimisation of code outside the numeric kernels (MRSNS_GLUE_OPTIMIZATION)
# in Release builds; after the build type's -O3, so it wins.
function(mrsns_glue_flags target)
  if(NOT MRSNS_GLUE_OPTIMIZATION OR NOT CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    return()
  endif()
  target_compile_options(${target} PRIVATE $<$<CONFIG:Release>:${MRSNS_GLUE_OPTIMIZATION}>)
endfunction()

# mrsns_add_module(<name> [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
#
# Builds modules/<name>/src/*.cpp into the library mrsns_<name>, aliased
# mrsns::<name>, with modules/<name>/include as its public include directory.
function(mrsns_add_module name)
  cmake_parse_arguments(ARG "" "" "PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB _sources CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp")
  file(GLOB_RECURSE _headers CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/include/*.h")
  add_library(mrsns_${name} STATIC ${_sources} ${_headers})
  add_library(mrsns::${name} ALIAS mrsns_${name})
  target_include_directories(mrsns_${name}
    PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(mrsns_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS} mrsns_warnings)
  set_target_properties(mrsns_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  mrsns_unity_exclusions(mrsns_${name})
  if(NOT name IN_LIST MRSNS_KERNEL_MODULES)
    mrsns_glue_flags(mrsns_${name})
  endif()
  set_property(GLOBAL APPEND PROPERTY MRSNS_MODULES mrsns_${name})
endfunction()

# mrsns_add_test(<module> [LIBS ...])
#
# One GoogleTest program per tests/<module> folder (every *.cpp in it), each
# TEST registered with CTest. Tests find the shared data like the programs do
# (core/data_dir.h: MRSNS_DATA_DIR from the environment, else the cache
# variable compiled in) and the build tree through MRSNS_TEST_BINARY_DIR
# (tests/support).
#
# SERIAL takes a gtest filter of load tests (e.g. "StreamRobustness.*"): they
# run with CTest's RUN_SERIAL, alone on the machine. They put a 2-core machine
# under a load of their own and bound what a good client sees; another test
# running beside them would measure the CI machine instead of the server.
function(mrsns_add_test module)
  cmake_parse_arguments(ARG "" "SERIAL" "LIBS" ${ARGN})
  file(GLOB _sources CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/*.cpp")
  set(_exe mrsns_${module}_tests)
  if(NOT _sources)
    message(STATUS "tests/${module}: no test sources yet")
    return()
  endif()
  add_executable(${_exe} ${_sources})
  target_link_libraries(${_exe} PRIVATE ${ARG_LIBS} mrsns_test_support GTest::gmock GTest::gtest_main mrsns_warnings)
  mrsns_unity_exclusions(${_exe})
  mrsns_test_flags(${_exe})
  # Listing a program's tests is its first run: on a cold cache it loads VTK/ITK/Qt, which took over CMake's 5 s
  # default once in a CI run (the whole ctest run then failed), so allow a minute.
  if(ARG_SERIAL)
    gtest_discover_tests(${_exe}
      TEST_PREFIX "${module}."
      TEST_FILTER "-${ARG_SERIAL}"
      DISCOVERY_MODE PRE_TEST
      DISCOVERY_TIMEOUT 60
      PROPERTIES LABELS ${module})
    gtest_discover_tests(${_exe}
      TEST_PREFIX "${module}."
      TEST_FILTER "${ARG_SERIAL}"
      DISCOVERY_MODE PRE_TEST
      DISCOVERY_TIMEOUT 60
      PROPERTIES LABELS ${module} RUN_SERIAL TRUE)
  else()
    gtest_discover_tests(${_exe}
      TEST_PREFIX "${module}."
      DISCOVERY_MODE PRE_TEST
      DISCOVERY_TIMEOUT 60
      PROPERTIES LABELS ${module})
  endif()
endfunction()

# Collects the link closure of a target (names of every library it pulls in).
function(_mrsns_link_closure target out_var)
  set(_seen "")
  set(_todo ${target})
  while(_todo)
    list(POP_FRONT _todo _t)
    if(_t IN_LIST _seen)
      continue()
    endif()
    list(APPEND _seen ${_t})
    if(NOT TARGET ${_t})
      continue()
    endif()
    get_target_property(_type ${_t} TYPE)
    set(_deps "")
    if(NOT _type STREQUAL "INTERFACE_LIBRARY")
      get_target_property(_link ${_t} LINK_LIBRARIES)
      if(_link)
        list(APPEND _deps ${_link})
      endif()
    endif()
    get_target_property(_ilink ${_t} INTERFACE_LINK_LIBRARIES)
    if(_ilink)
      list(APPEND _deps ${_ilink})
    endif()
    foreach(_d IN LISTS _deps)
      # Strip generator expressions such as $<LINK_ONLY:...> down to the name.
      string(REGEX REPLACE "^\\$<[A-Z_]+:(.*)>$" "\\1" _d "${_d}")
      if(_d MATCHES "^\\$<" OR _d STREQUAL "")
        continue()
      endif()
      list(APPEND _todo ${_d})
    endforeach()
  endwhile()
  set(${out_var} ${_seen} PARENT_SCOPE)
endfunction()

# Fails the configuration when a module under modules/ links Qt (directly or
# through a dependency such as VTK::GUISupportQt) or includes a Qt header.
function(mrsns_check_module_boundaries)
  get_property(_modules GLOBAL PROPERTY MRSNS_MODULES)
  foreach(_m IN LISTS _modules)
    _mrsns_link_closure(${_m} _closure)
    foreach(_lib IN LISTS _closure)
      if(_lib MATCHES "^Qt[0-9]*::" OR _lib MATCHES "^VTK::(GUISupportQt|RenderingQt|ViewsQt)$"
         OR _lib MATCHES "libQt[0-9]")
        message(FATAL_ERROR "Module boundary violated: ${_m} links ${_lib}. "
          "Only app/gui may use Qt (see ARCHITECTURE.md); move the Qt code to app/gui.")
      endif()
    endforeach()
  endforeach()
  file(GLOB_RECURSE _module_sources "${CMAKE_SOURCE_DIR}/modules/*.h" "${CMAKE_SOURCE_DIR}/modules/*.cpp")
  foreach(_f IN LISTS _module_sources)
    file(STRINGS "${_f}" _qt_includes REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](Q[A-Z][A-Za-z]*|Qt[A-Za-z]*/|QVTK)")
    if(_qt_includes)
      message(FATAL_ERROR "Module boundary violated: ${_f} includes Qt (${_qt_includes}). "
        "Only app/gui may use Qt (see ARCHITECTURE.md).")
    endif()
  endforeach()
endfunction()

# The device boundary of ARCHITECTURE.md: the workstation acquires every
# measurement from devices and files, never from the simulated operating room.
# Fails the configuration when a workstation target (workflow, the GUI, the
# CLI) links mrsns_simulation, directly or through any dependency, or when a
# source outside modules/simulation, app/sim and tests includes its headers.
function(mrsns_check_simulation_boundary)
  set(_workstation mrsns_workflow mrsns mrsns-cli mrsns_cli_verbs mrsns_gui_lib)
  get_property(_modules GLOBAL PROPERTY MRSNS_MODULES)
  foreach(_t IN LISTS _workstation _modules)
    if(NOT TARGET ${_t} OR _t STREQUAL "mrsns_simulation")
      continue()
    endif()
    _mrsns_link_closure(${_t} _closure)
    foreach(_lib IN LISTS _closure)
      if(_lib STREQUAL "mrsns_simulation" OR _lib STREQUAL "mrsns::simulation")
        message(FATAL_ERROR "Device boundary violated: ${_t} links ${_lib}. Only app/sim (mrsns-sim) may link "
          "the simulated operating room; the workstation talks to it through the device protocols "
          "(see ARCHITECTURE.md, 'The device boundary').")
      endif()
    endforeach()
  endforeach()
  file(GLOB_RECURSE _sources "${CMAKE_SOURCE_DIR}/modules/*.h" "${CMAKE_SOURCE_DIR}/modules/*.cpp"
    "${CMAKE_SOURCE_DIR}/app/*.h" "${CMAKE_SOURCE_DIR}/app/*.cpp")
  foreach(_f IN LISTS _sources)
    if(_f MATCHES "/modules/simulation/" OR _f MATCHES "/app/sim/")
      continue()
    endif()
    file(STRINGS "${_f}" _includes REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"]mrsns/simulation/")
    if(_includes)
      message(FATAL_ERROR "Device boundary violated: ${_f} includes the simulation (${_includes}). "
        "Only app/sim may use it (see ARCHITECTURE.md, 'The device boundary').")
    endif()
  endforeach()
endfunction()
