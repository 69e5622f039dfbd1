# cmake -DBUILD_DIR= -DPYTHON= -DWORK_DIR= -P run_python_install.cmake
# `cmake --install --component python` into a prefix puts the module where that prefix's Python finds it:
#   - a venv made at the prefix imports it with no PYTHONPATH (its own site-packages);
#   - in a plain prefix P it lands in the interpreter's platlib for P, and PYTHONPATH=<that dir> imports it.
# Python snippets are written without ';', which would split them into several arguments here.
cmake_minimum_required(VERSION 3.20)
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(run_out "${out}" PARENT_SCOPE)
endfunction()

# Imports papertear with `python` and checks it came from under `prefix`, not from the build tree.
function(expect_import python prefix)
  run(${CMAKE_COMMAND} -E env --unset=PYTHONPATH ${ARGN} ${python} -c [=[
import papertear
print(papertear.__version__)
print(papertear.__file__)
]=])
  if(NOT run_out MATCHES "^[0-9]+\\.[0-9]+\\.[0-9]+\n([^\n]+)\n$")
    message(FATAL_ERROR "unexpected output of import papertear:\n${run_out}")
  endif()
  file(REAL_PATH "${CMAKE_MATCH_1}" module)
  file(REAL_PATH "${prefix}" prefix_real)
  string(FIND "${module}" "${prefix_real}/" at)
  if(NOT at EQUAL 0)
    message(FATAL_ERROR "papertear was imported from ${module}, not from the installed ${prefix}")
  endif()
  message("${python} ${ARGN}: papertear ${run_out}")
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})

# A venv at the prefix: its interpreter searches only its own site-packages (and the standard library).
set(venv ${WORK_DIR}/venv)
run(${PYTHON} -m venv --without-pip ${venv})
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${venv} --component python)
run(${venv}/bin/python -c [=[
import sysconfig
print(sysconfig.get_path("platlib"), end="")
]=])
file(GLOB module ${run_out}/papertear*.so)
if(NOT module)
  file(GLOB_RECURSE installed RELATIVE ${venv} ${venv}/*papertear*)
  message(FATAL_ERROR "the module is not in the venv's platlib ${run_out}; installed: ${installed}")
endif()
expect_import(${venv}/bin/python ${venv})

# A plain prefix: the directory the interpreter reports for it, named by PYTHONPATH.
set(prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} --component python)
run(${PYTHON} -c [=[
import sys, sysconfig
scheme = getattr(sysconfig, "get_default_scheme", lambda: "posix_prefix")()
scheme = "posix_prefix" if scheme == "posix_local" else scheme
print(sysconfig.get_path("platlib", scheme, vars={"base": sys.argv[1], "platbase": sys.argv[1]}), end="")
]=] ${prefix})
set(platlib ${run_out})
file(GLOB module ${platlib}/papertear*.so)
if(NOT module)
  file(GLOB_RECURSE installed RELATIVE ${prefix} ${prefix}/*)
  message(FATAL_ERROR "the module is not in ${platlib}; installed: ${installed}")
endif()
expect_import(${PYTHON} ${prefix} PYTHONPATH=${platlib})
