// The dashboard's HTTP side: static assets (web/) and the JSON and PNG endpoints its pages read.
//
//   GET  /                        web/index.html (the single-page dashboard)
//   GET  /static/<file>           web/<file>; /static/vendor/chart.js/<file> from web/node_modules/chart.js/dist
//   GET  /api/meta                parameter sets, firmware versions, default set
//   GET  /api/stats               fleet figures (paper Fig. 6, 7, 8, 12) for a filter, by day and by firmware
//   GET  /api/runs                runs, keyset-paginated (?after_ms=&after_id=), with report counters
//   GET  /api/runs/<id>           one run: report summary, decisions, ambiguous views, regions
//   GET  /api/runs/<id>/graph     the rerun child's pose graph: nodes, edges by kind, components, views,
//                                 hypothesis edges and conditional merges from the decisions
//   GET  /api/runs/<id>/map/{parent,child,difference}.png   the grids the protrusion detector compared
//   POST /api/runs/<id>/regions/<region>/label   {"label": "protrusion"|"new_space", "parameter_set": ...}
//   GET  /api/labels              labelled regions
//   GET  /api/compare?a=&b=       two parameter sets: fleet-wide deltas and the runs that changed most
//   GET  /api/jobs                reprocessing jobs with progress, newest first
//   GET  /api/robots              robots with their map history summary (current, newest, pending, findings)
//   GET  /api/robots/<id>/maps    the robot's map versions, oldest first, with current_version and
//                                 head_version (what repairs start from)
//   GET  /api/robots/<id>/maps/<v>            one version (<v> a number or "current") with its findings
//   GET  /api/robots/<id>/maps/<v>/graph      its pose graph: nodes [id, x, y, θ, component, added by the
//                                             version's run 0/1], edges with χ² and hypothesis, components,
//                                             and the frame of map.png
//   GET  /api/robots/<id>/maps/<v>/map.png    its home component's occupancy grid
//   GET  /api/robots/<id>/maps/<v>/export/{map.pgm,map.yaml,map.g2o}   downloads (ROS map_server, g2o)
//   POST /api/robots/<id>/maps/<v>/repair     {"action": "reject_edge", "from", "to", "view"} | {"action":
//                                             "reject_hypothesis", "hypothesis"} | {"action": "cut_finding",
//                                             "finding_id"} | {"action": "rollback"|"undo"}, "reason", "approve"
//   POST /api/robots/<id>/maps/<v>/review     {"approve": true|false}
//
// Every /api/ route needs a bearer token (MakeHttpAccessGuard: the same tokens and roles as gRPC; robots
// read only their own runs and map); the POSTs (label, repair, review) also need a role that may do them
// (engineer or admin; server/auth.h). Every read answers from FleetQueries (server/fleet_queries.h), the
// same service behind the Queries gRPC service; routes are path templates (http::MatchPath), one per resource.
// Statistics come from storage's roll-up and lists are keyset pages, so pages cost the same at 500k runs.
// Errors are JSON {"error": "..."} with an HTTP status that matches storage's Status code.
//
// The web directory: $FLEETD_WEB_DIR when set, else the source tree's web/ as configured at build time,
// else "web" next to the fleetd binary.
//
// Thread safety: the handlers are safe from many connection threads (storage and the authenticator are;
// the PNG cache has its own mutex).
#pragma once

#include "server/auth.h"
#include "server/config.h"
#include "server/http_server.h"
#include "storage/repository.h"

namespace server {

/// Adds the routes above to `router`. `repository` and `authenticator` must outlive the HTTP server.
void RegisterDashboardRoutes(HttpRouter& router, storage::Repository& repository,
                             Authenticator& authenticator, const FleetdConfig& config);
/// The access rules of every HTTP route (server/src/http_access.cc, docs/formats/service.md "HTTP"): install
/// with HttpRouter::SetGuard. `repository` and `authenticator` must outlive the HTTP server.
HttpGuard MakeHttpAccessGuard(storage::Repository& repository, Authenticator& authenticator,
                              const FleetdConfig& config);
/// The /api/robots routes (server/src/dashboard_map_routes.cc).
void RegisterMapRoutes(HttpRouter& router, storage::Repository& repository, Authenticator& authenticator,
                       const FleetdConfig& config);

}  // namespace server
