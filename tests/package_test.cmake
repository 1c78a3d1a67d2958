# ctest's package_test: installs the build tree into a fresh prefix, builds
# examples/cpp against it with find_package(splitray 0.1), runs the program on the
# vendored horse (and once more built by hand with pkg-config's flags), and checks that a
# version the package is not compatible with is refused,
# and runs examples/python with the installed Python module (when PYTHON is given).
# Arguments: -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DMESH=... -DLIBDIR=lib [-DPYTHON=... -DPYTHON_DIR=...]
# [-DSANITIZE_FLAGS="-fsanitize=..." (a sanitized build) -DPYTHON_ENV="VAR=value;..." (for Python)]
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "failed (${code}): ${ARGN}\n${out}\n${err}")
  endif()
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/cpp -B ${WORK_DIR}/build
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
    "-DCMAKE_CXX_FLAGS=${SANITIZE_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${SANITIZE_FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer ${MESH})
# The same program through pkg-config (relocatable .pc: found from the prefix it was put in).
find_program(PKG_CONFIG pkg-config REQUIRED)
find_program(CXX NAMES c++ g++ REQUIRED)
execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${WORK_DIR}/prefix/${LIBDIR}/pkgconfig
                ${PKG_CONFIG} --cflags --libs splitray
                RESULT_VARIABLE code OUTPUT_VARIABLE flags ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "pkg-config --cflags --libs splitray failed: ${err}")
endif()
separate_arguments(flags UNIX_COMMAND "${flags} ${SANITIZE_FLAGS}")
run(${CXX} -O1 ${SOURCE_DIR}/examples/cpp/main.cpp -o ${WORK_DIR}/consumer_pc ${flags})
run(${WORK_DIR}/consumer_pc ${MESH})
if(PYTHON)
  run(${CMAKE_COMMAND} -E env PYTHONPATH=${WORK_DIR}/prefix/${PYTHON_DIR} ${PYTHON_ENV}
      ${PYTHON} ${SOURCE_DIR}/examples/python/cast_rays.py ${MESH})
endif()
# find_package(splitray 1.0) must fail: the version file says 0.1.x.
file(WRITE ${WORK_DIR}/v1/CMakeLists.txt
  "cmake_minimum_required(VERSION 3.25)\nproject(v1 CXX)\nfind_package(splitray 1.0 REQUIRED)\n")
execute_process(COMMAND ${CMAKE_COMMAND} -S ${WORK_DIR}/v1 -B ${WORK_DIR}/v1/build
                -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix RESULT_VARIABLE code OUTPUT_QUIET ERROR_QUIET)
if(code EQUAL 0)
  message(FATAL_ERROR "find_package(splitray 1.0) accepted the 0.1 package")
endif()
file(REMOVE_RECURSE ${WORK_DIR})
