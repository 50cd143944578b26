# The command of a test whose tool was missing when CMake configured (add_missing_tool_test in
# tests/CMakeLists.txt): it fails, printing what is missing and how to install it.
#   cmake -DMESSAGE=TEXT -P missing_tool.cmake
message(FATAL_ERROR "${MESSAGE}")
