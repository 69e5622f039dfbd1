# cmake -DBUILD_DIR= -DSOURCE_DIR= -DWORK_DIR= -DGENERATOR= -DCXX_COMPILER= -DBUILD_TYPE= -P run_consumer.cmake
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
# The C++ package only (the Python module has its own install component).
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} --component Unspecified)
file(GLOB_RECURSE config RELATIVE ${prefix} ${prefix}/*/papertearConfig.cmake)
foreach(f include/papertear/papertear.hpp include/papertear/engine/simulation.hpp include/papertear/engine/api.hpp
          include/papertear/components/sheet.hpp include/papertear/engine/version.hpp
          share/papertear/scenarios/start-inward.json ${config})
  if(NOT config OR NOT EXISTS ${prefix}/${f})
    file(GLOB_RECURSE installed RELATIVE ${prefix} ${prefix}/*)
    message(FATAL_ERROR "not installed: ${f}\ninstalled: ${installed}")
  endif()
endforeach()

run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
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
