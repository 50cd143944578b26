// Mapper parameter sets on the wire (fleet.v1.ParameterSet) and in JSON files, translated to slamcore's
// MapperParams. Unset fields keep slamcore's documented defaults; unknown JSON keys and invalid values are
// refused with a message naming the field.
//
// Thread safety: free functions without shared state.
#pragma once

#include <cstddef>
#include <string>

#include "fleet/v1/report.pb.h"
#include "slamcore/mapper_params.h"

namespace analyzer {

/// The defaults of slamcore, as a proto with every field set.
fleet::v1::MapperParameters ToProto(const slamcore::MapperParams& params);

/// Unset fields keep slamcore's defaults: a parameter set names only what it changes.
slamcore::Result<slamcore::MapperParams> FromProto(const fleet::v1::MapperParameters& proto);

/// The largest parameter-set JSON accepted: a whole set with every field is about 2 kB, so this leaves room
/// for a long description while bounding the two parses of it (keys, then values).
inline constexpr std::size_t kMaxParameterSetJsonBytes = 256 * 1024;

/// Parses a JSON parameter set, e.g. {"name": "strict", "mapper": {"gate_chi2": 9.0}}, or a bare
/// MapperParameters object ({"gate_chi2": 9.0}); `source` prefixes errors. At most kMaxParameterSetJsonBytes.
slamcore::Result<fleet::v1::ParameterSet> ParseParameterSetJson(const std::string& json,
                                                                const std::string& source);
slamcore::Result<fleet::v1::ParameterSet> ReadParameterSetFile(const std::string& path);
/// The Mapper parameters a parameter-set file names (ReadParameterSetFile, then FromProto): what the tools'
/// `--params FILE` runs the Mapper with.
slamcore::Result<slamcore::MapperParams> ReadMapperParamsFile(const std::string& path);

}  // namespace analyzer
