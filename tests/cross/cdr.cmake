# CDR: polyport's XCDR1/XCDR2 codec against Cyclone DDS 0.10 (C code from idlc) and Fast DDS
# 2.9 (C++ code from fastddsgen 2.3), all from the same IDL file (cdr/cdr_cross.idl). The
# generators run at build time into the build tree; each vendor gets one small peer library,
# and one GoogleTest executable compares the bytes and values both ways. A vendor whose SDK
# or generator is missing is left out (with a message); with neither there is no test.
set(cdr_cross_source_dir ${CMAKE_CURRENT_SOURCE_DIR}/cdr)
set(cdr_cross_gen_dir ${CMAKE_CURRENT_BINARY_DIR}/cdr_gen)
set(cdr_cross_idl ${cdr_cross_source_dir}/cdr_cross.idl)
set(cdr_cross_peers)
set(cdr_cross_definitions)

find_package(CycloneDDS CONFIG QUIET)
find_program(POLYPORT_IDLC idlc)
if(TARGET CycloneDDS::ddsc AND POLYPORT_IDLC)
  set(cyclone_gen_dir ${cdr_cross_gen_dir}/cyclone)
  add_custom_command(
    OUTPUT ${cyclone_gen_dir}/cdr_cross.c ${cyclone_gen_dir}/cdr_cross.h
    COMMAND ${CMAKE_COMMAND} -E make_directory ${cyclone_gen_dir}
    COMMAND ${POLYPORT_IDLC} -Wno-implicit-extensibility -o ${cyclone_gen_dir} ${cdr_cross_idl}
    DEPENDS ${cdr_cross_idl}
    COMMENT "idlc: C types for the CDR cross tests"
    VERBATIM)
  # Generated code is not held to polyport's warning flags (SYSTEM include, no warnings).
  add_library(polyport_cdr_cyclone_peer STATIC
    ${cyclone_gen_dir}/cdr_cross.c ${cdr_cross_source_dir}/cyclone_peer.cpp)
  target_include_directories(polyport_cdr_cyclone_peer SYSTEM PRIVATE ${cyclone_gen_dir})
  target_include_directories(polyport_cdr_cyclone_peer PUBLIC ${cdr_cross_source_dir})
  target_compile_definitions(polyport_cdr_cyclone_peer PUBLIC POLYPORT_CDR_CYCLONE=1)
  target_link_libraries(polyport_cdr_cyclone_peer PUBLIC CycloneDDS::ddsc)
  list(APPEND cdr_cross_peers polyport_cdr_cyclone_peer)
else()
  message(STATUS "CDR cross tests: Cyclone DDS left out (CycloneDDS package or idlc not found; "
                 "Debian: apt install cyclonedds-dev cyclonedds-tools)")
endif()

find_package(fastcdr CONFIG QUIET)
find_package(fastrtps CONFIG QUIET)
find_program(POLYPORT_FASTDDSGEN fastddsgen)
if(TARGET fastcdr AND TARGET fastrtps AND POLYPORT_FASTDDSGEN)
  set(fastdds_gen_dir ${cdr_cross_gen_dir}/fastdds)
  set(fastdds_generated
    ${fastdds_gen_dir}/cdr_cross.cxx ${fastdds_gen_dir}/cdr_crossPubSubTypes.cxx
    ${fastdds_gen_dir}/cdr_cross.h ${fastdds_gen_dir}/cdr_crossPubSubTypes.h)
  # fastddsgen (Java) writes temporary files into the working directory.
  add_custom_command(
    OUTPUT ${fastdds_generated}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${fastdds_gen_dir}
    COMMAND ${POLYPORT_FASTDDSGEN} -replace -ppDisable -d ${fastdds_gen_dir} ${cdr_cross_idl}
    DEPENDS ${cdr_cross_idl}
    WORKING_DIRECTORY ${cdr_cross_gen_dir}
    COMMENT "fastddsgen: C++ types for the CDR cross tests"
    VERBATIM)
  add_library(polyport_cdr_fastdds_peer STATIC
    ${fastdds_gen_dir}/cdr_cross.cxx ${fastdds_gen_dir}/cdr_crossPubSubTypes.cxx
    ${cdr_cross_source_dir}/fastdds_peer.cpp)
  target_include_directories(polyport_cdr_fastdds_peer SYSTEM PRIVATE ${fastdds_gen_dir})
  target_include_directories(polyport_cdr_fastdds_peer PUBLIC ${cdr_cross_source_dir})
  target_compile_definitions(polyport_cdr_fastdds_peer PUBLIC POLYPORT_CDR_FASTDDS=1)
  target_link_libraries(polyport_cdr_fastdds_peer PUBLIC fastrtps fastcdr)
  polyport_sdk_generated_code(polyport_cdr_fastdds_peer)  # Fast CDR templates (tests/sanitizers/ubsan.supp)
  list(APPEND cdr_cross_peers polyport_cdr_fastdds_peer)
else()
  message(STATUS "CDR cross tests: Fast DDS left out (fastcdr/fastrtps packages or fastddsgen not "
                 "found; Debian: apt install libfastrtps-dev libfastcdr-dev fastddsgen)")
endif()

if(NOT cdr_cross_peers)
  message(STATUS "CDR cross tests skipped: no reference implementation found")
  return()
endif()

add_executable(polyport_cdr_cross_tests ${cdr_cross_source_dir}/cdr_cross_test.cpp)
target_link_libraries(polyport_cdr_cross_tests PRIVATE
  polyport::core ${cdr_cross_peers} GTest::gtest_main polyport_warnings)
target_compile_definitions(polyport_cdr_cross_tests PRIVATE POLYPORT_CDR_CROSS_IDL="${cdr_cross_idl}")
gtest_discover_tests(polyport_cdr_cross_tests PROPERTIES LABELS integration TIMEOUT 120 DISCOVERY_TIMEOUT 60)
