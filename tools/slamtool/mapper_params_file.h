// Mapper parameters from a JSON file: an object whose keys are MapperParams' field names, nested for the
// acceptance criteria, e.g. {"gate_chi2": 9.0, "recovery": {"min_observations": 4, "min_views": 2}}.
// Missing keys keep their defaults; unknown keys, wrong types and invalid values are refused with a
// message naming the key.
#pragma once

#include <string>

#include "slamcore/mapper_params.h"

namespace slamtool {

slamcore::Result<slamcore::MapperParams> ReadMapperParams(const std::string& path);
slamcore::Result<slamcore::MapperParams> ParseMapperParams(const std::string& json_text, const std::string& source);

}  // namespace slamtool
