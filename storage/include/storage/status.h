// storage reports failures with the project's one Status and Result (slamcore/status.h, target slamcore_status,
// which depends on the standard library only; storage knows nothing else of slamcore). These names are aliases,
// not a second type, so that storage's signatures read as before.
#pragma once

#include "slamcore/status.h"

namespace storage {

using slamcore::Result;
using slamcore::Status;
using slamcore::StatusCode;
using slamcore::StatusCodeName;

using slamcore::Aborted;
using slamcore::AlreadyExists;
using slamcore::DataLoss;
using slamcore::FailedPrecondition;
using slamcore::Internal;
using slamcore::InvalidArgument;
using slamcore::NotFound;
using slamcore::Unavailable;

}  // namespace storage
