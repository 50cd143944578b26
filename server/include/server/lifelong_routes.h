// GET /api/lifelong: the lifelong experiment's results for the dashboard's fleet page — the JSON object
// `fleetsim --lifelong --results FILE` wrote, named by `fleetd --lifelong-results FILE`, without its
// per-robot detail (engineers and admins; robots are refused by the access guard like every fleet route).
// 404 when no file is configured, 413 when the file is over 32 MiB, 500 when it does not parse or lacks
// "regimes". The file is read on each request (it is small, and a new experiment may replace it).
//
// Thread safety: the handler reads the file on the calling thread; safe from many threads.
#pragma once

#include "server/config.h"
#include "server/http_server.h"

namespace server {

void RegisterLifelongRoutes(HttpRouter& router, const FleetdConfig& config);

}  // namespace server
