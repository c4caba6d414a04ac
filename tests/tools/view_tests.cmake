# lagrangectl view: ViewBrowser.* drive the page in headless chromium (label browser: a real browser, a few
# seconds each); ViewTest's bad-input tests need none.
find_package(PkgConfig REQUIRED)
pkg_check_modules(test_cpp_httplib REQUIRED IMPORTED_TARGET cpp-httplib)
add_executable(tools_view_tests ${CMAKE_CURRENT_LIST_DIR}/view_test.cpp)
target_link_libraries(tools_view_tests PRIVATE lagrange_tools lagrange_test_support lagrange_test_lcm
                                               nlohmann_json::nlohmann_json PkgConfig::test_cpp_httplib GTest::gtest_main)
target_compile_definitions(tools_view_tests PRIVATE
  LAGRANGE_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
  LAGRANGED_PATH="$<TARGET_FILE:lagranged>"
  LAGRANGECTL_PATH="$<TARGET_FILE:lagrangectl>"
  VIEW_SCREENSHOT_PATH="${PROJECT_BINARY_DIR}/tests/tools/view_panda_and_arm.png")  # the README's picture
add_dependencies(tools_view_tests lagranged lagrangectl)
# The browser tests need the optimised programs (scripts/test runs label browser in its Release tree): a
# sanitizer tree registers only ViewTest, which drives the same server without a browser.
if(NOT LAGRANGE_SANITIZE)
  gtest_discover_tests(tools_view_tests TEST_FILTER "ViewBrowser.*" DISCOVERY_TIMEOUT 60
                       PROPERTIES TIMEOUT 120 LABELS browser)
endif()
gtest_discover_tests(tools_view_tests TEST_FILTER "ViewTest.*" DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 60)
