// ToProto / FromProto between storage records and the service messages (fleet/v1/service.proto).
#pragma once

#include "fleet/v1/service.pb.h"
#include "server/fleet_queries.h"
#include "storage/records.h"
#include "storage/status.h"

namespace server {

/// INVALID_ARGUMENT naming `field` for NaN/inf or reversed times.
storage::Result<storage::RunFilter> FromProto(const fleet::v1::RunFilter& filter, const std::string& field);
fleet::v1::RunFilter ToProto(const storage::RunFilter& filter);

fleet::v1::FleetFigures ToProto(const Figures& figures);
/// b − a, counts and shares.
fleet::v1::FleetFigures Delta(const fleet::v1::FleetFigures& a, const fleet::v1::FleetFigures& b);

fleet::v1::Job ToProto(const storage::JobRecord& job);
fleet::v1::Region ToProto(const storage::ProtrusionRegionRecord& region);
fleet::v1::RobotMapSummary ToProto(const storage::RobotMapSummary& summary);

}  // namespace server
