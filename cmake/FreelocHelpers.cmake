# freeloc_module(NAME <name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates the library freeloc_<name> (alias freeloc::<name>), installed and exported.
function(freeloc_module)
  cmake_parse_arguments(M "" "NAME" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target freeloc_${M_NAME})
  add_library(${target} ${M_SOURCES})
  add_library(freeloc::${M_NAME} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${M_NAME} OUTPUT_NAME freeloc_${M_NAME})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  target_link_libraries(${target} PUBLIC ${M_PUBLIC_DEPS} PRIVATE ${M_PRIVATE_DEPS})
  install(TARGETS ${target} EXPORT freelocTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/freeloc/${M_NAME}
    FILES_MATCHING PATTERN "*.h")
endfunction()

# freeloc_test(NAME <name> SOURCES ... DEPS ...)
# A GoogleTest binary whose cases are registered with CTest one by one.
function(freeloc_test)
  if(NOT FREELOC_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(T "" "NAME" "SOURCES;DEPS" ${ARGN})
  add_executable(${T_NAME} ${T_SOURCES})
  target_compile_options(${T_NAME} PRIVATE -Wall -Wextra)
  target_compile_definitions(${T_NAME} PRIVATE
    FREELOC_SHARED_DIR="${PROJECT_SOURCE_DIR}/../shared"
    FREELOC_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    FREELOC_BINARY_DIR="${PROJECT_BINARY_DIR}")
  target_link_libraries(${T_NAME} PRIVATE ${T_DEPS} freeloc_testing GTest::gtest_main)
  gtest_discover_tests(${T_NAME} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 600)
endfunction()
