# ThreadSanitizer lane (deploy/sanitizers.sh): included as CMAKE_PROJECT_INCLUDE into a Release build.
# Only the code that runs on fleetd's threads and the server tests is instrumented: server/, storage/,
# analyzer/, the uploader the integration tests drive, and the executables. slamcore/ and the generated
# protos stay at the Release flags (ccache hits from the main build; races there go unseen, but they hold no
# shared state), so the lane builds in minutes instead of half an hour. Every executable links libtsan.
cmake_language(DEFER CALL fleet_instrument_for_tsan)
function(fleet_instrument_for_tsan)
  set(instrumented server storage analyzer sim_uploader fleetd fleetctl server_tests fleetd_integration_tests
                   fleetd_map_repair_tests fleetd_hostile_tests fleetd_operations_tests fleetd_erasure_tests)
  foreach(target IN LISTS instrumented)
    target_compile_options(${target} PRIVATE -fsanitize=thread -O1 -g1 -fno-omit-frame-pointer)
  endforeach()
endfunction()
