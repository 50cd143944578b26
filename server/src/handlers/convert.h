// ToProto / FromProto between storage records and the service messages (fleet/v1/service.proto).
#pragma once

#include "fleet/v1/service.pb.h"
#include "storage/records.h"
#include "storage/status.h"

namespace server {

/// INVALID_ARGUMENT naming `field` for NaN/inf or reversed times.
storage::Result<storage::RunFilter> FromProto(const fleet::v1::RunFilter& filter, const std::string& field);
fleet::v1::RunFilter ToProto(const storage::RunFilter& filter);

fleet::v1::FleetFigures ToProto(const storage::FleetStatistics& statistics);
/// b − a, counts and shares.
fleet::v1::FleetFigures Delta(const fleet::v1::FleetFigures& a, const fleet::v1::FleetFigures& b);

fleet::v1::Job ToProto(const storage::JobRecord& job);
fleet::v1::Region ToProto(const storage::ProtrusionRegionRecord& region);

/// "2026-01-01" for a day number since the Unix epoch (storage's GroupBy::kDay key).
std::string DayKey(const std::string& days_since_epoch);

}  // namespace server
