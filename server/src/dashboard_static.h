// The dashboard's static shell (docs: dashboard_routes.h): GET / and /index.html, /static/<file> from web/,
// /static/vendor/chart.js/<file> from web/node_modules/chart.js/dist. Open without a token: no data in them.
#pragma once

#include "server/http_server.h"

namespace server {

/// Adds GET "/" (every GET path no longer route claims) to `router`.
void RegisterStaticRoutes(HttpRouter& router);

}  // namespace server
