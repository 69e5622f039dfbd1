# cmake -DBUILD_DIR= -DSOURCE_DIR= -DWORK_DIR= -DGENERATOR= -DCXX_COMPILER= -DBUILD_TYPE= [-DSHARED=ON]
#       -P run_consumer.cmake
# SHARED=ON: BUILD_DIR is ignored; the project is configured and built here with BUILD_SHARED_LIBS=ON (the
# library only: no apps, tests, bench, Python module or MPI) and that build is installed.
include(${CMAKE_CURRENT_LIST_DIR}/readme_block.cmake)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(run_out "${out}" PARENT_SCOPE)
endfunction()

# The README's C++ example is the consumer's main.cpp, verbatim.
readme_block(${SOURCE_DIR}/README.md cpp readme_cpp)
file(READ ${SOURCE_DIR}/examples/consumer/main.cpp main_cpp)
if(NOT readme_cpp STREQUAL main_cpp)
  message(FATAL_ERROR "README.md '## Embedding' C++ block differs from examples/consumer/main.cpp")
endif()

set(prefix ${WORK_DIR}/prefix)
file(REMOVE_RECURSE ${WORK_DIR})
if(SHARED)
  string(TIMESTAMP started "%s")
  set(BUILD_DIR ${WORK_DIR}/project)
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${BUILD_DIR} -G ${GENERATOR} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
      -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DBUILD_SHARED_LIBS=ON -DPAPERTEAR_BUILD_APPS=OFF
      -DPAPERTEAR_BUILD_TESTS=OFF -DPAPERTEAR_BUILD_BENCH=OFF -DPAPERTEAR_BUILD_PYTHON=OFF -DPAPERTEAR_WITH_MPI=OFF)
  # Two jobs at the lowest priority: the machine running the suite is shared.
  find_program(NICE nice)
  run(${NICE} -n 19 ${CMAKE_COMMAND} --build ${BUILD_DIR} -j 2)
  string(TIMESTAMP built "%s")
  math(EXPR seconds "${built} - ${started}")
  message("shared build: ${seconds} s")
endif()
# The C++ package only (the Python module has its own install component).
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} --component Unspecified)
file(GLOB_RECURSE config RELATIVE ${prefix} ${prefix}/*/papertearConfig.cmake)
foreach(f include/papertear/engine/version.hpp share/papertear/scenarios/start-inward.json ${config})
  if(NOT config OR NOT EXISTS ${prefix}/${f})
    file(GLOB_RECURSE installed RELATIVE ${prefix} ${prefix}/*)
    message(FATAL_ERROR "not installed: ${f}\ninstalled: ${installed}")
  endif()
endforeach()

# Exactly the public headers (docs/architecture.md "Public and internal headers"): no systems/, no
# internals; and each one's own includes resolve inside the installed tree.
file(GLOB_RECURSE headers RELATIVE ${prefix}/include ${prefix}/include/*)
list(SORT headers)
set(public papertear/components/errors.hpp papertear/components/obstacles.hpp papertear/components/sheet.hpp papertear/engine/api.hpp
    papertear/engine/batch.hpp papertear/engine/result_writer.hpp papertear/engine/scenario.hpp
    papertear/engine/simulation.hpp papertear/engine/version.hpp papertear/papertear.hpp)
if(NOT headers STREQUAL public)
  message(FATAL_ERROR "installed headers:\n  ${headers}\nexpected the public ones:\n  ${public}")
endif()
foreach(h IN LISTS headers)
  file(STRINGS ${prefix}/include/${h} includes REGEX "^#include \"")
  get_filename_component(dir ${prefix}/include/${h} DIRECTORY)
  foreach(line IN LISTS includes)
    string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" included "${line}")
    if(NOT EXISTS ${dir}/${included})
      message(FATAL_ERROR "${h}: #include \"${included}\" is not in the installed tree")
    endif()
  endforeach()
endforeach()

# The exported targets name no CGAL, and a consumer's include directory is <prefix>/include only.
file(GLOB targets_files ${prefix}/*/cmake/papertear/papertearTargets*.cmake)
foreach(f IN LISTS targets_files)
  file(READ ${f} text)
  if(text MATCHES "CGAL|include/papertear")
    message(FATAL_ERROR "${f} names CGAL or include/papertear:\n${text}")
  endif()
endforeach()

# papertearConfig.cmake must not look for CGAL (nor, for a shared build, oneTBB or libpng): a disabled
# package that a REQUIRED find_dependency asks for fails the configure.
set(hidden -DCMAKE_DISABLE_FIND_PACKAGE_CGAL=ON)
if(SHARED)
  list(APPEND hidden -DCMAKE_DISABLE_FIND_PACKAGE_TBB=ON -DCMAKE_DISABLE_FIND_PACKAGE_PNG=ON)
  file(GLOB archives ${prefix}/lib*/*.a)
  file(GLOB shared_library ${prefix}/lib*/libpapertear.so)
  if(archives OR NOT shared_library)
    message(FATAL_ERROR "a shared build installs libpapertear.so and no archive; got ${shared_library} ${archives}")
  endif()
endif()
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix} ${hidden})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
if(SHARED)
  file(GET_RUNTIME_DEPENDENCIES EXECUTABLES ${WORK_DIR}/build/tear RESOLVED_DEPENDENCIES_VAR deps
       UNRESOLVED_DEPENDENCIES_VAR missing)
  list(FILTER deps INCLUDE REGEX "libpapertear\\.so")
  if(NOT deps MATCHES "^${prefix}/")
    message(FATAL_ERROR "tear does not load the installed libpapertear.so: ${deps} (unresolved: ${missing})")
  endif()
endif()
# The consumer's CMakeLists.txt chooses no C++ standard: the target brings C++20. The scenario is the
# installed one.
run(${WORK_DIR}/build/tear ${prefix}/share/papertear/scenarios/start-inward.json)
message("${run_out}")
if(NOT run_out MATCHES "tears [0-9]+, pieces [1-9][0-9]*\nhash [0-9a-f]+\n")
  message(FATAL_ERROR "unexpected output of the consumer:\n${run_out}")
endif()

# A bad scenario: exit 2, the file named on stderr.
execute_process(COMMAND ${WORK_DIR}/build/tear ${SOURCE_DIR}/examples/consumer/CMakeLists.txt
  RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
if(NOT rc EQUAL 2 OR NOT err MATCHES "CMakeLists.txt")
  message(FATAL_ERROR "bad scenario: exit ${rc}, stderr: ${err}")
endif()
