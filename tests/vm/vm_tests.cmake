# Tests labelled vm need SocketCAN, which the host kernel of the development and CI
# machines lacks: their commands run through scripts/vcan-run, which gives them vcan
# interfaces of their own (a user-mode-linux guest here, a private network namespace on a
# kernel with vcan). When the runner cannot work, the test fails with its one-line reason.
set(POLYPORT_VCAN_RUN ${PROJECT_SOURCE_DIR}/scripts/vcan-run)
# A guest boots in about half a second; these bound a failure, not a run time.
set(POLYPORT_VM_TEST_TIMEOUT 60)
set(POLYPORT_VM_CTEST_TIMEOUT 120)  # above vcan-run's own watchdog (timeout + 30 s)

# The runner's options every vm test gets, then the test's own.
function(_polyport_vcan_run_args out_var)
  set(${out_var} --timeout ${POLYPORT_VM_TEST_TIMEOUT} --rw ${CMAKE_BINARY_DIR} ${ARGN} PARENT_SCOPE)
endfunction()

# polyport_add_vm_test(NAME name [RUNNER_ARGS vcan-run options...] COMMAND command args...)
#   One ctest, label vm: `scripts/vcan-run <options> -- command args...`.
#   RUNNER_ARGS e.g. --fd, --interfaces 2, --private (see scripts/vcan-run --help).
function(polyport_add_vm_test)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "NAME" "RUNNER_ARGS;COMMAND")
  if(NOT arg_NAME OR NOT arg_COMMAND)
    message(FATAL_ERROR "polyport_add_vm_test needs NAME and COMMAND")
  endif()
  _polyport_vcan_run_args(runner_args ${arg_RUNNER_ARGS})
  add_test(NAME ${arg_NAME} COMMAND ${POLYPORT_VCAN_RUN} ${runner_args} -- ${arg_COMMAND})
  set_tests_properties(${arg_NAME} PROPERTIES LABELS vm TIMEOUT ${POLYPORT_VM_CTEST_TIMEOUT})
endfunction()

# polyport_discover_vm_gtests(TARGET target [RUNNER_ARGS vcan-run options...])
#   One ctest per GoogleTest case (gtest_discover_tests), label vm, each in a guest of its
#   own. gtest_discover_tests puts a target's CROSSCOMPILING_EMULATOR before the binary,
#   both to list the cases at build time and to run each; tests/vm/gtest-launcher lists
#   them right on the host (listing needs no CAN, so a machine without a working guest
#   still builds) and runs each case through scripts/vcan-run.
function(polyport_discover_vm_gtests)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "TARGET" "RUNNER_ARGS")
  if(NOT arg_TARGET)
    message(FATAL_ERROR "polyport_discover_vm_gtests needs TARGET")
  endif()
  _polyport_vcan_run_args(runner_args ${arg_RUNNER_ARGS})
  set_property(TARGET ${arg_TARGET} PROPERTY CROSSCOMPILING_EMULATOR
    ${PROJECT_SOURCE_DIR}/tests/vm/gtest-launcher ${POLYPORT_VCAN_RUN} ${runner_args} --)
  gtest_discover_tests(${arg_TARGET} PROPERTIES LABELS vm TIMEOUT ${POLYPORT_VM_CTEST_TIMEOUT}
    DISCOVERY_TIMEOUT 60)
endfunction()
