# LCM: polyport's .lcm parser, fingerprint and codec against the C code lcm-gen generates
# from the same files (lcm/). lcm-gen runs at build time; the generated C needs only
# lcm/lcm_coretypes.h (--c-no-pubsub), so liblcm itself is not linked.
find_program(POLYPORT_LCM_GEN lcm-gen)
find_path(POLYPORT_LCM_INCLUDE_DIR lcm/lcm_coretypes.h)
if(NOT POLYPORT_LCM_GEN OR NOT POLYPORT_LCM_INCLUDE_DIR)
  message(STATUS "LCM cross tests skipped: lcm-gen or lcm/lcm_coretypes.h not found "
                 "(Debian: apt install liblcm-bin liblcm-dev)")
  return()
endif()

set(lcm_cross_source_dir ${CMAKE_CURRENT_SOURCE_DIR}/lcm)
set(lcm_cross_gen_dir ${CMAKE_CURRENT_BINARY_DIR}/lcm_gen)
file(GLOB_RECURSE lcm_cross_files CONFIGURE_DEPENDS ${lcm_cross_source_dir}/*.lcm)
# lcm-gen writes one .c/.h pair per struct, named <package>_<struct>: the types the .lcm files
# declare, which the test uses by name anyway.
set(lcm_cross_types
  demo_temperature_t demo_pair_t
  xtest_inner_point_t xtest_primitives_t xtest_arrays_t
  xtest_nested_t xtest_segment_t xtest_empty_t xtest_holder_t)
set(lcm_cross_generated)
foreach(type ${lcm_cross_types})
  list(APPEND lcm_cross_generated ${lcm_cross_gen_dir}/${type}.c ${lcm_cross_gen_dir}/${type}.h)
endforeach()
add_custom_command(
  OUTPUT ${lcm_cross_generated}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${lcm_cross_gen_dir}
  COMMAND ${POLYPORT_LCM_GEN} -c --c-no-pubsub --c-cpath ${lcm_cross_gen_dir} --c-hpath ${lcm_cross_gen_dir}
          ${lcm_cross_files}
  DEPENDS ${lcm_cross_files}
  COMMENT "lcm-gen -c: C code for the LCM cross tests"
  VERBATIM)

# Generated code is not held to polyport's warning flags. The headers are listed too, so the
# test's sources wait for lcm-gen through this library.
add_library(polyport_lcm_generated STATIC ${lcm_cross_generated} ${lcm_cross_source_dir}/lcm_c_helpers.c)
target_include_directories(polyport_lcm_generated PUBLIC ${lcm_cross_gen_dir} ${POLYPORT_LCM_INCLUDE_DIR})

add_executable(polyport_lcm_cross_tests ${lcm_cross_source_dir}/lcm_cross_test.cpp)
target_link_libraries(polyport_lcm_cross_tests PRIVATE
  polyport::core polyport_lcm_generated GTest::gtest_main polyport_warnings)
target_compile_definitions(polyport_lcm_cross_tests PRIVATE POLYPORT_LCM_CROSS_DIR="${lcm_cross_source_dir}")
gtest_discover_tests(polyport_lcm_cross_tests PROPERTIES LABELS integration TIMEOUT 60 DISCOVERY_TIMEOUT 60)
