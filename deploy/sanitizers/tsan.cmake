# ThreadSanitizer lane (deploy/sanitizers.sh): included as CMAKE_PROJECT_INCLUDE into a Release build.
# Only the code that runs on fleetd's threads and the server tests is instrumented: server/, storage/,
# analyzer/, the client library the integration tests drive (fleet_client, sim_service), and the executables.
# slamcore/ and the generated protos stay at the Release flags (ccache hits from the main build; races there go
# unseen, but they hold no shared state), so the lane builds in minutes instead of half an hour. Every
# executable links libtsan.
cmake_language(DEFER CALL fleet_instrument_for_tsan)
function(fleet_instrument_for_tsan)
  set(instrumented server storage analyzer fleet_client sim_service fleetd fleetctl server_tests fleet_client_tests
                   fleetd_integration_tests fleetd_map_repair_tests fleetd_hostile_tests fleetd_operations_tests fleetd_erasure_tests)
  foreach(target IN LISTS instrumented)
    target_compile_options(${target} PRIVATE -fsanitize=thread -O1 -g1 -fno-omit-frame-pointer)
  endforeach()
endfunction()
