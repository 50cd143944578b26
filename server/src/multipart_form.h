// multipart/form-data (RFC 7578) as browsers send a form with files: the dashboard's map_server upload (a YAML
// and its image). Internal to server/.
//
// Bounds: at most `max_parts` parts, 8 KiB of headers per part; names and file names of at most 255 bytes.
// Errors name what is wrong ("multipart: part 2 has no Content-Disposition name"). Thread safety: pure.
#pragma once

#include <string>
#include <vector>

#include "storage/status.h"

namespace server::http {

struct FormPart {
  std::string name;      // Content-Disposition name
  std::string filename;  // Content-Disposition filename (empty for a plain field)
  std::string body;
};

/// `content_type`: the request's Content-Type header, which must be multipart/form-data with a boundary.
storage::Result<std::vector<FormPart>> ParseMultipartForm(const std::string& content_type,
                                                          const std::string& body, std::size_t max_parts = 8);

}  // namespace server::http
