// Integration tests: a real fleetd on loopback, driven over gRPC and HTTP like robots and engineers would.
#include <gtest/gtest.h>
#include <grpcpp/generic/generic_stub.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>
#include <nlohmann/json.hpp>
#include <thread>

#include "fleetd_process.h"
#include "status_matchers.h"

namespace fleetd_test {
namespace {

using fleet::v1::RunFile;
using fleet::v1::UploadRunResponse;

class FleetdTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    server_ = new FleetdProcess();
    ASSERT_TRUE(server_->ok());
    auto channel = server_->Channel();
    ingest_ = fleet::v1::Ingest::NewStub(channel).release();
    queries_ = fleet::v1::Queries::NewStub(channel).release();
    reprocessing_ = fleet::v1::Reprocessing::NewStub(channel).release();
    labels_ = fleet::v1::Labels::NewStub(channel).release();
    models_ = fleet::v1::Models::NewStub(channel).release();
    admin_ = fleet::v1::Admin::NewStub(channel).release();
    engineer_ = new std::string(Token("engineer:alice"));
    ASSERT_FALSE(SimulatedRuns().empty());
  }
  static void TearDownTestSuite() {
    delete ingest_;
    delete queries_;
    delete reprocessing_;
    delete labels_;
    delete models_;
    delete admin_;
    EXPECT_EQ(server_->Stop(), 0) << "fleetd exits 0 on SIGTERM";
    delete server_;
    delete engineer_;
  }

  static std::string Token(const std::string& principal) { return IssueToken(*admin_, principal); }
  static std::string RobotToken(const std::string& robot_id) {
    return fleetd_test::RobotToken(*admin_, robot_id);
  }

  // Uploads every simulated run once (idempotent) and waits for their default reports.
  static void UploadAll() {
    for (const RunFile& run : SimulatedRuns()) {
      UploadRunResponse response;
      const grpc::Status status = Upload(*ingest_, RobotToken(run.header().robot_id()), run, &response);
      ASSERT_THAT(status, IsOk());
    }
  }
  static grpc::Status WaitForReport(const std::string& run_id, const std::string& set,
                                    fleet::v1::RunReport* out, int seconds = 90) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
    grpc::Status status;
    while (std::chrono::steady_clock::now() < until) {
      fleet::v1::GetRunReportRequest request;
      request.set_run_id(run_id);
      request.set_parameter_set(set);
      fleet::v1::GetRunReportResponse response;
      auto context = Context(*engineer_);
      status = queries_->GetRunReport(context.get(), request, &response);
      if (status.ok()) {
        if (out != nullptr) *out = response.report();
        return status;
      }
      if (status.error_code() != grpc::StatusCode::NOT_FOUND) return status;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return status;
  }
  static int CountRuns() { return fleetd_test::CountRuns(*queries_, *engineer_); }

  static FleetdProcess* server_;
  static fleet::v1::Ingest::Stub* ingest_;
  static fleet::v1::Queries::Stub* queries_;
  static fleet::v1::Reprocessing::Stub* reprocessing_;
  static fleet::v1::Labels::Stub* labels_;
  static fleet::v1::Models::Stub* models_;
  static fleet::v1::Admin::Stub* admin_;
  static std::string* engineer_;
};

FleetdProcess* FleetdTest::server_ = nullptr;
fleet::v1::Ingest::Stub* FleetdTest::ingest_ = nullptr;
fleet::v1::Queries::Stub* FleetdTest::queries_ = nullptr;
fleet::v1::Reprocessing::Stub* FleetdTest::reprocessing_ = nullptr;
fleet::v1::Labels::Stub* FleetdTest::labels_ = nullptr;
fleet::v1::Models::Stub* FleetdTest::models_ = nullptr;
fleet::v1::Admin::Stub* FleetdTest::admin_ = nullptr;
std::string* FleetdTest::engineer_ = nullptr;

TEST_F(FleetdTest, UploadThenAnalysisReport) {
  const auto& runs = SimulatedRuns();
  const RunFile& first = runs.front();
  UploadRunResponse response;
  grpc::Status status = Upload(*ingest_, RobotToken(first.header().robot_id()), first, &response);
  ASSERT_THAT(status, IsOk());
  EXPECT_EQ(response.run_id(), first.header().run_id());
  EXPECT_FALSE(response.already_present());
  EXPECT_EQ(response.events_stored(), static_cast<std::uint64_t>(first.events_size()));
  EXPECT_EQ(response.child_snapshot_id().size(), 64u);
  EXPECT_GT(response.analysis_job_id(), 0);
  UploadAll();
  for (const RunFile& run : runs) {
    fleet::v1::RunReport report;
    status = WaitForReport(run.header().run_id(), "", &report);
    ASSERT_THAT(status, IsOk()) << run.header().run_id() << ": " << status.error_message();
    EXPECT_EQ(report.run_id(), run.header().run_id());
    EXPECT_EQ(report.parameter_set(), "default");
    EXPECT_EQ(report.robot_id(), run.header().robot_id());
    EXPECT_GT(report.views_total(), 0);
    EXPECT_GT(report.counts().components_created(), 0);
    EXPECT_GT(report.divergence().rerun_nodes(), 0);
    EXPECT_TRUE(report.has_ground_truth()) << "fleetsim runs carry ground truth";
    EXPECT_FALSE(report.has_rerun_child()) << "left out unless asked for";
  }
}

TEST_F(FleetdTest, DuplicateAndRetriedUploadsStoreOneRun) {
  UploadAll();
  const int before = CountRuns();
  const RunFile& run = SimulatedRuns()[1];  // has a parent map
  ASSERT_GT(run.parent_snapshot().nodes_size(), 0);
  UploadRunResponse first, again, by_id;
  ASSERT_THAT(Upload(*ingest_, RobotToken(run.header().robot_id()), run, &first), IsOk());
  EXPECT_TRUE(first.already_present());
  EXPECT_EQ(first.analysis_job_id(), 0);
  // A retry that names the parent by id instead of sending it is the same run.
  UploadOptions options;
  options.send_parent = false;
  options.parent_id = first.parent_snapshot_id();
  grpc::Status status = Upload(*ingest_, RobotToken(run.header().robot_id()), run, &by_id, options);
  ASSERT_THAT(status, IsOk());
  EXPECT_TRUE(by_id.already_present());
  // Concurrent duplicates: all succeed, one run.
  std::vector<std::thread> threads;
  std::atomic<int> ok{0};
  for (int i = 0; i < 4; ++i) {
    threads.emplace_back([&] {
      UploadRunResponse response;
      if (Upload(*ingest_, RobotToken(run.header().robot_id()), run, &response).ok()) ++ok;
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(ok.load(), 4);
  EXPECT_EQ(CountRuns(), before);
  // A different payload under the same run id is a conflict.
  RunFile changed = run;
  changed.mutable_header()->set_firmware("9.9.9");
  status = Upload(*ingest_, RobotToken(run.header().robot_id()), changed, &again);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::ALREADY_EXISTS) << status.error_message();
  EXPECT_NE(status.error_message().find("header.run_id"), std::string::npos) << status.error_message();
}

TEST_F(FleetdTest, CutStreamStoresNothingAndRetrySucceeds) {
  RunFile run = SimulatedRuns()[2];
  fleet::v1::RunHeader header = run.header();
  header.set_run_id("cut-stream-run");
  header.set_started_at(header.started_at() + 30 * 86400.0);  // outside the other tests' time range
  header.set_ended_at(header.ended_at() + 30 * 86400.0);
  *run.mutable_header() = header;
  const int before = CountRuns();
  UploadRunResponse response;
  UploadOptions cut;
  cut.cancel_after_messages = 2;  // header and one chunk, then the connection is cut
  cut.events_per_chunk = 50;
  grpc::Status status = Upload(*ingest_, RobotToken(run.header().robot_id()), run, &response, cut);
  EXPECT_FALSE(status.ok());
  // A stream that ends cleanly without the child snapshot is refused as well.
  UploadOptions no_child;
  no_child.send_child = false;
  status = Upload(*ingest_, RobotToken(run.header().robot_id()), run, &response, no_child);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("child_snapshot"), std::string::npos) << status.error_message();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(CountRuns(), before) << "nothing half-stored";
  status = Upload(*ingest_, RobotToken(run.header().robot_id()), run, &response);
  ASSERT_THAT(status, IsOk());
  EXPECT_FALSE(response.already_present());
  EXPECT_EQ(CountRuns(), before + 1);
}

TEST_F(FleetdTest, ListRunsPagesAndFilters) {
  UploadAll();
  const int total = CountRuns();
  ASSERT_GE(total, 4);
  std::set<std::string> seen;
  std::string token;
  int pages = 0;
  do {
    fleet::v1::ListRunsRequest request;
    request.set_page_size(1);
    request.set_page_token(token);
    fleet::v1::ListRunsResponse response;
    auto context = Context(*engineer_);
    ASSERT_THAT(queries_->ListRuns(context.get(), request, &response), IsOk());
    for (const auto& run : response.runs()) seen.insert(run.run_id());
    token = response.next_page_token();
    ++pages;
  } while (!token.empty() && pages < 100);
  EXPECT_EQ(static_cast<int>(seen.size()), total);

  fleet::v1::ListRunsRequest request;
  request.mutable_filter()->set_robot_id("robot-1");
  request.mutable_filter()->set_started_from(1767225600.0);
  request.mutable_filter()->set_started_before(1767225600.0 + 2 * 86400.0);
  fleet::v1::ListRunsResponse response;
  auto context = Context(*engineer_);
  ASSERT_THAT(queries_->ListRuns(context.get(), request, &response), IsOk());
  EXPECT_EQ(response.runs_size(), 2);
  for (const auto& run : response.runs()) {
    EXPECT_EQ(run.robot_id(), "robot-1");
    EXPECT_EQ(run.firmware(), "1.5.0");
  }
  request.mutable_filter()->Clear();
  request.mutable_filter()->set_firmware("1.4.2");
  request.mutable_filter()->set_parameter_set("default");
  response.Clear();
  context = Context(*engineer_);
  ASSERT_THAT(queries_->ListRuns(context.get(), request, &response), IsOk());
  for (const auto& run : response.runs()) EXPECT_EQ(run.firmware(), "1.4.2");
}

TEST_F(FleetdTest, FleetStatisticsTotalsAndTrends) {
  UploadAll();
  for (const RunFile& run : SimulatedRuns())
    ASSERT_THAT(WaitForReport(run.header().run_id(), "", nullptr), IsOk());
  fleet::v1::GetFleetStatisticsRequest request;
  request.mutable_filter()->set_parameter_set("default");
  request.mutable_filter()->set_started_before(1767225600.0 + 2 * 86400.0);
  request.set_group_by(fleet::v1::GROUP_BY_DAY);
  fleet::v1::GetFleetStatisticsResponse response;
  auto context = Context(*engineer_);
  grpc::Status status = queries_->GetFleetStatistics(context.get(), request, &response);
  ASSERT_THAT(status, IsOk());
  EXPECT_EQ(response.total().reports(), 4);
  EXPECT_EQ(response.total().robots(), 2);
  EXPECT_GT(response.total().views_total(), 0);
  EXPECT_GE(response.total().ambiguous_view_share(), 0.0);
  EXPECT_LE(response.total().ambiguous_view_share(), 1.0);
  ASSERT_EQ(response.groups_size(), 2);
  EXPECT_EQ(response.groups(0).key(), "2026-01-01");
  EXPECT_EQ(response.groups(1).key(), "2026-01-02");
  request.set_group_by(fleet::v1::GROUP_BY_FIRMWARE);
  response.Clear();
  context = Context(*engineer_);
  ASSERT_THAT(queries_->GetFleetStatistics(context.get(), request, &response), IsOk());
  ASSERT_EQ(response.groups_size(), 2);
  EXPECT_EQ(response.groups(0).key(), "1.4.2");
}

TEST_F(FleetdTest, ReprocessWithSecondParameterSetAndCompare) {
  UploadAll();
  fleet::v1::PutParameterSetRequest put;
  put.mutable_parameter_set()->set_name("strict-merge");
  put.mutable_parameter_set()->mutable_mapper()->mutable_merge_full()->set_min_observations(8);
  put.mutable_parameter_set()->mutable_mapper()->mutable_recovery()->set_min_observations(8);
  put.mutable_parameter_set()->mutable_mapper()->set_gate_chi2(4.0);
  fleet::v1::PutParameterSetResponse put_response;
  auto context = Context(*engineer_);
  grpc::Status status = reprocessing_->PutParameterSet(context.get(), put, &put_response);
  ASSERT_THAT(status, IsOk());
  // Same set again is fine; same name with other values is a conflict.
  context = Context(*engineer_);
  ASSERT_THAT(reprocessing_->PutParameterSet(context.get(), put, &put_response), IsOk());
  EXPECT_TRUE(put_response.already_present());
  put.mutable_parameter_set()->mutable_mapper()->set_gate_chi2(5.0);
  context = Context(*engineer_);
  EXPECT_EQ(reprocessing_->PutParameterSet(context.get(), put, &put_response).error_code(),
            grpc::StatusCode::ALREADY_EXISTS);

  fleet::v1::StartJobRequest start;
  start.set_parameter_set("strict-merge");
  start.mutable_filter()->set_started_before(1767225600.0 + 2 * 86400.0);
  fleet::v1::Job job;
  context = Context(*engineer_);
  status = reprocessing_->StartJob(context.get(), start, &job);
  ASSERT_THAT(status, IsOk());
  EXPECT_EQ(job.kind(), "reprocess");
  EXPECT_EQ(job.parameter_set(), "strict-merge");

  fleet::v1::GetJobRequest watch;
  watch.set_job_id(job.job_id());
  context = Context(*engineer_, 120);
  auto reader = reprocessing_->WatchJob(context.get(), watch);
  fleet::v1::Job update, last;
  int updates = 0;
  while (reader->Read(&update)) {
    EXPECT_LE(update.progress_done(), std::max<std::int64_t>(update.progress_total(), 0));
    last = update;
    ++updates;
  }
  status = reader->Finish();
  ASSERT_THAT(status, IsOk());
  EXPECT_GE(updates, 1);
  EXPECT_EQ(last.state(), "done");
  EXPECT_EQ(last.progress_total(), 4);
  EXPECT_EQ(last.progress_done(), 4);

  // Results sit beside the originals.
  const std::string run_id = SimulatedRuns()[1].header().run_id();
  fleet::v1::RunReport strict, original;
  ASSERT_THAT(WaitForReport(run_id, "strict-merge", &strict, 5), IsOk());
  ASSERT_THAT(WaitForReport(run_id, "default", &original, 5), IsOk());
  EXPECT_EQ(strict.parameter_set(), "strict-merge");
  EXPECT_EQ(original.parameter_set(), "default");
  fleet::v1::ListRunsRequest list;
  list.mutable_filter()->set_parameter_set("strict-merge");
  fleet::v1::ListRunsResponse listed;
  context = Context(*engineer_);
  ASSERT_THAT(queries_->ListRuns(context.get(), list, &listed), IsOk());
  ASSERT_EQ(listed.runs_size(), 4);
  EXPECT_EQ(listed.runs(0).report_parameter_sets_size(), 2);

  fleet::v1::CompareParameterSetsRequest compare;
  compare.set_set_a("default");
  compare.set_set_b("strict-merge");
  compare.set_top(10);
  compare.mutable_filter()->set_started_before(1767225600.0 + 2 * 86400.0);
  fleet::v1::CompareParameterSetsResponse compared;
  context = Context(*engineer_);
  status = queries_->CompareParameterSets(context.get(), compare, &compared);
  ASSERT_THAT(status, IsOk());
  EXPECT_EQ(compared.runs_compared(), 4);
  EXPECT_EQ(compared.a().reports(), compared.b().reports());
  EXPECT_EQ(compared.most_changed_size(), 4);
  for (int i = 1; i < compared.most_changed_size(); ++i) {
    EXPECT_GE(compared.most_changed(i - 1).change(), compared.most_changed(i).change());
  }
  EXPECT_EQ(compared.delta().recovery_created(),
            compared.b().recovery_created() - compared.a().recovery_created());

  // Listing and cancelling.
  fleet::v1::ListJobsRequest jobs_request;
  jobs_request.set_kind("reprocess");
  fleet::v1::ListJobsResponse jobs;
  context = Context(*engineer_);
  ASSERT_THAT(reprocessing_->ListJobs(context.get(), jobs_request, &jobs), IsOk());
  ASSERT_GE(jobs.jobs_size(), 1);
  EXPECT_EQ(jobs.jobs(0).job_id(), job.job_id());
  fleet::v1::CancelJobRequest cancel;
  cancel.set_job_id(job.job_id());
  fleet::v1::Job cancelled;
  context = Context(*engineer_);
  EXPECT_EQ(reprocessing_->CancelJob(context.get(), cancel, &cancelled).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION)
      << "a finished job cannot be cancelled";
  start.set_parameter_set("default");
  context = Context(*engineer_);
  ASSERT_THAT(reprocessing_->StartJob(context.get(), start, &job), IsOk());
  cancel.set_job_id(job.job_id());
  context = Context(*engineer_);
  status = reprocessing_->CancelJob(context.get(), cancel, &cancelled);
  if (status.ok()) {
    EXPECT_EQ(cancelled.state(), "cancelled");
  } else {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);  // it was quicker than us
  }
}

TEST_F(FleetdTest, LabelRegionsTrainEvaluateActivate) {
  UploadAll();
  struct Found {
    std::string run_id;
    std::int64_t region_id;
  };
  std::vector<Found> regions;
  for (const RunFile& run : SimulatedRuns()) {
    ASSERT_THAT(WaitForReport(run.header().run_id(), "", nullptr), IsOk());
    fleet::v1::ListRegionsRequest request;
    request.set_run_id(run.header().run_id());
    fleet::v1::ListRegionsResponse response;
    auto context = Context(*engineer_);
    ASSERT_THAT(labels_->ListRegions(context.get(), request, &response), IsOk());
    for (const auto& region : response.regions()) regions.push_back({region.run_id(), region.region_id()});
  }
  fleet::v1::LabelRegionRequest label;
  label.set_run_id(SimulatedRuns()[0].header().run_id());
  label.set_region_id(1000000);
  label.set_label("protrusion");
  fleet::v1::LabelRegionResponse labelled;
  auto context = Context(*engineer_);
  grpc::Status status = labels_->LabelRegion(context.get(), label, &labelled);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(status.error_message().find("region_id"), std::string::npos) << status.error_message();
  label.set_label("maybe");
  context = Context(*engineer_);
  status = labels_->LabelRegion(context.get(), label, &labelled);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("label"), std::string::npos);
  if (regions.size() < 2) GTEST_SKIP() << "the simulated runs produced " << regions.size() << " regions";

  for (std::size_t i = 0; i < regions.size(); ++i) {
    label.set_run_id(regions[i].run_id);
    label.set_region_id(regions[i].region_id);
    label.set_label(i % 2 == 0 ? "protrusion" : "new_space");
    context = Context(*engineer_);
    status = labels_->LabelRegion(context.get(), label, &labelled);
    ASSERT_THAT(status, IsOk());
    EXPECT_EQ(labelled.region().label(), label.label());
    EXPECT_EQ(labelled.region().labelled_by(), "engineer:alice");
  }
  fleet::v1::GetRunReportRequest report_request;
  report_request.set_run_id(regions[0].run_id);
  fleet::v1::GetRunReportResponse report;
  context = Context(*engineer_);
  ASSERT_THAT(queries_->GetRunReport(context.get(), report_request, &report), IsOk());
  bool label_seen = false;
  for (const auto& region : report.report().protrusion_regions())
    label_seen |= region.label() == "protrusion";
  EXPECT_TRUE(label_seen) << "reports show current labels";

  fleet::v1::TrainModelRequest train;
  train.set_name("protrusion");
  train.set_classifier("decision_tree");
  fleet::v1::TrainModelResponse trained;
  context = Context(*engineer_);
  EXPECT_EQ(models_->TrainModel(context.get(), train, &trained).error_code(),
            grpc::StatusCode::PERMISSION_DENIED)
      << "models are for admins";
  context = Context(FleetdProcess::AdminToken(), 120);
  status = models_->TrainModel(context.get(), train, &trained);
  ASSERT_THAT(status, IsOk());
  EXPECT_EQ(trained.model().version(), 1);
  EXPECT_EQ(trained.model().classifier(), "decision_tree");
  EXPECT_EQ(trained.training_regions(), static_cast<std::int64_t>(regions.size()));

  fleet::v1::ActivateModelRequest activate;
  activate.set_name("protrusion");
  activate.set_version(1);
  fleet::v1::Model model;
  context = Context(FleetdProcess::AdminToken());
  ASSERT_THAT(models_->ActivateModel(context.get(), activate, &model), IsOk());
  EXPECT_TRUE(model.active());
  fleet::v1::EvaluateModelRequest evaluate;
  evaluate.set_name("protrusion");
  fleet::v1::EvaluateModelResponse evaluation;
  context = Context(*engineer_);
  ASSERT_THAT(models_->EvaluateModel(context.get(), evaluate, &evaluation), IsOk());
  EXPECT_EQ(evaluation.regions(), static_cast<std::int64_t>(regions.size()));
  EXPECT_EQ(evaluation.model().version(), 1);
  fleet::v1::ListModelsRequest list;
  list.set_name("protrusion");
  fleet::v1::ListModelsResponse listed;
  context = Context(*engineer_);
  ASSERT_THAT(models_->ListModels(context.get(), list, &listed), IsOk());
  ASSERT_EQ(listed.models_size(), 1);
  EXPECT_TRUE(listed.models(0).active());
}

TEST_F(FleetdTest, AuthenticationAndPermissionFailures) {
  const RunFile& run = SimulatedRuns()[0];
  UploadRunResponse response;
  EXPECT_EQ(Upload(*ingest_, "", run, &response).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(Upload(*ingest_, "robot:robot-0.deadbeef", run, &response).error_code(),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(Upload(*ingest_, "garbage", run, &response).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  // A robot writes only its own runs.
  grpc::Status status = Upload(*ingest_, RobotToken("robot-1"), run, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_NE(status.error_message().find("header.robot_id"), std::string::npos) << status.error_message();
  // Robots cannot read; engineers cannot mint credentials.
  fleet::v1::ListRunsRequest list;
  fleet::v1::ListRunsResponse listed;
  auto context = Context(RobotToken("robot-0"));
  EXPECT_EQ(queries_->ListRuns(context.get(), list, &listed).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  fleet::v1::SetCredentialRequest credential;
  credential.set_principal("admin:mallory");
  fleet::v1::SetCredentialResponse minted;
  context = Context(*engineer_);
  EXPECT_EQ(admin_->SetCredential(context.get(), credential, &minted).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  // A replaced credential stops working.
  const std::string old_token = Token("engineer:bob");
  const std::string new_token = Token("engineer:bob");
  context = Context(old_token);
  EXPECT_EQ(queries_->ListRuns(context.get(), list, &listed).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  context = Context(new_token);
  EXPECT_THAT(queries_->ListRuns(context.get(), list, &listed), IsOk());
}

// Every malformed upload gets INVALID_ARGUMENT (or the code given) naming the field, and stores nothing.
TEST_F(FleetdTest, BadUploadsNameTheFieldAndStoreNothing) {
  UploadAll();
  const int before = CountRuns();
  const RunFile& good = SimulatedRuns()[1];
  const std::string token = RobotToken(good.header().robot_id());
  struct Case {
    std::string name;
    std::function<void(RunFile&)> mutate;
    grpc::StatusCode code;
    std::string field;
  };
  auto odometry_index = [](const RunFile& run) {
    for (int i = 0; i < run.events_size(); ++i) {
      if (run.events(i).has_odometry()) return i;
    }
    return -1;
  };
  const int odo = odometry_index(good);
  ASSERT_GE(odo, 0);
  const std::vector<Case> cases = {
      {"format version", [](RunFile& r) { r.mutable_header()->set_format_version(2); },
       grpc::StatusCode::INVALID_ARGUMENT, "format_version"},
      {"no run id", [](RunFile& r) { r.mutable_header()->set_run_id(""); },
       grpc::StatusCode::INVALID_ARGUMENT, "run_id"},
      {"covariance size",
       [odo](RunFile& r) { r.mutable_events(odo)->mutable_odometry()->mutable_covariance()->RemoveLast(); },
       grpc::StatusCode::INVALID_ARGUMENT, "events[" + std::to_string(odo) + "].odometry.covariance"},
      {"nan",
       [odo](RunFile& r) {
         r.mutable_events(odo)->mutable_odometry()->mutable_increment()->set_x(std::nan(""));
       },
       grpc::StatusCode::INVALID_ARGUMENT, "events[" + std::to_string(odo) + "]"},
      {"event count", [](RunFile& r) { r.mutable_header()->set_event_count(r.header().event_count() + 1); },
       grpc::StatusCode::INVALID_ARGUMENT, "header.event_count"},
      {"empty child", [](RunFile& r) { r.mutable_child_snapshot()->Clear(); },
       grpc::StatusCode::INVALID_ARGUMENT, "child_snapshot"},
      {"child version", [](RunFile& r) { r.mutable_child_snapshot()->set_format_version(7); },
       grpc::StatusCode::INVALID_ARGUMENT, "child_snapshot"},
  };
  for (const Case& c : cases) {
    RunFile bad = good;
    std::string run_id = "bad-" + c.name;
    std::replace(run_id.begin(), run_id.end(), ' ', '-');
    bad.mutable_header()->set_run_id(run_id);
    c.mutate(bad);
    UploadRunResponse response;
    const grpc::Status status = Upload(*ingest_, token, bad, &response);
    EXPECT_EQ(status.error_code(), c.code) << c.name << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(c.field), std::string::npos)
        << c.name << ": " << status.error_message();
  }
  // Parent named by an id the server does not hold, and not sent.
  UploadOptions options;
  options.send_parent = false;
  options.parent_id = std::string(64, 'a');
  RunFile bad = good;
  bad.mutable_header()->set_run_id("bad-parent-id");
  UploadRunResponse response;
  grpc::Status status = Upload(*ingest_, token, bad, &response, options);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_NE(status.error_message().find("header.parent_snapshot_id"), std::string::npos);
  // Parent sent but its hash differs from the header's id.
  options.send_parent = true;
  status = Upload(*ingest_, token, bad, &response, options);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("parent_snapshot"), std::string::npos);

  // Out-of-order and empty stream messages.
  {
    auto context = Context(token);
    auto writer = ingest_->UploadRun(context.get(), &response);
    fleet::v1::UploadRunRequest message;
    *message.mutable_events()->add_events() = good.events(0);
    writer->Write(message);
    writer->WritesDone();
    status = writer->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("message[0]"), std::string::npos) << status.error_message();
  }
  {
    auto context = Context(token);
    auto writer = ingest_->UploadRun(context.get(), &response);
    fleet::v1::UploadRunRequest message;
    *message.mutable_header() = good.header();
    writer->Write(message);
    writer->Write(fleet::v1::UploadRunRequest());
    writer->WritesDone();
    status = writer->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("message[1]"), std::string::npos) << status.error_message();
  }
  {
    auto context = Context(token);
    auto writer = ingest_->UploadRun(context.get(), &response);
    writer->WritesDone();
    status = writer->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("header"), std::string::npos) << status.error_message();
  }
  EXPECT_EQ(CountRuns(), before) << "nothing half-stored";
}

TEST_F(FleetdTest, BadQueriesGetPreciseCodes) {
  auto expect = [](grpc::Status status, grpc::StatusCode code, const std::string& field) {
    EXPECT_EQ(status.error_code(), code) << status.error_message();
    EXPECT_NE(status.error_message().find(field), std::string::npos) << status.error_message();
  };
  {
    fleet::v1::GetRunReportRequest request;
    fleet::v1::GetRunReportResponse response;
    auto context = Context(*engineer_);
    expect(queries_->GetRunReport(context.get(), request, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "run_id");
    request.set_run_id("no-such-run");
    context = Context(*engineer_);
    expect(queries_->GetRunReport(context.get(), request, &response), grpc::StatusCode::NOT_FOUND, "run_id");
  }
  {
    fleet::v1::ListRunsRequest request;
    fleet::v1::ListRunsResponse response;
    request.set_page_size(5000);
    auto context = Context(*engineer_);
    expect(queries_->ListRuns(context.get(), request, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "page_size");
    request.set_page_size(10);
    request.set_page_token("not-a-token");
    context = Context(*engineer_);
    expect(queries_->ListRuns(context.get(), request, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "page_token");
    request.clear_page_token();
    request.mutable_filter()->set_started_from(100.0);
    request.mutable_filter()->set_started_before(50.0);
    context = Context(*engineer_);
    expect(queries_->ListRuns(context.get(), request, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "filter.started_before");
    request.mutable_filter()->set_started_from(std::numeric_limits<double>::infinity());
    context = Context(*engineer_);
    expect(queries_->ListRuns(context.get(), request, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "filter.started_from");
  }
  {
    fleet::v1::GetFleetStatisticsRequest request;
    request.set_group_by(static_cast<fleet::v1::GroupBy>(99));
    fleet::v1::GetFleetStatisticsResponse response;
    auto context = Context(*engineer_);
    expect(queries_->GetFleetStatistics(context.get(), request, &response),
           grpc::StatusCode::INVALID_ARGUMENT, "group_by");
    fleet::v1::CompareParameterSetsRequest compare;
    compare.set_set_a("default");
    fleet::v1::CompareParameterSetsResponse compared;
    context = Context(*engineer_);
    expect(queries_->CompareParameterSets(context.get(), compare, &compared),
           grpc::StatusCode::INVALID_ARGUMENT, "set_b");
    compare.set_set_b("nope");
    context = Context(*engineer_);
    expect(queries_->CompareParameterSets(context.get(), compare, &compared), grpc::StatusCode::NOT_FOUND,
           "set_b");
  }
  {
    fleet::v1::PutParameterSetRequest put;
    fleet::v1::PutParameterSetResponse response;
    put.mutable_parameter_set()->set_name("bad name!");
    auto context = Context(*engineer_);
    expect(reprocessing_->PutParameterSet(context.get(), put, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "parameter_set.name");
    put.mutable_parameter_set()->set_name("negative-gate");
    put.mutable_parameter_set()->mutable_mapper()->set_gate_chi2(-1.0);
    context = Context(*engineer_);
    expect(reprocessing_->PutParameterSet(context.get(), put, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "gate_chi2");
    fleet::v1::StartJobRequest start;
    fleet::v1::Job job;
    context = Context(*engineer_);
    expect(reprocessing_->StartJob(context.get(), start, &job), grpc::StatusCode::INVALID_ARGUMENT,
           "parameter_set");
    start.set_parameter_set("never-stored");
    context = Context(*engineer_);
    expect(reprocessing_->StartJob(context.get(), start, &job), grpc::StatusCode::NOT_FOUND, "parameter_set");
    fleet::v1::GetJobRequest get;
    get.set_job_id(987654);
    context = Context(*engineer_);
    expect(reprocessing_->GetJob(context.get(), get, &job), grpc::StatusCode::NOT_FOUND, "job_id");
    fleet::v1::CancelJobRequest cancel;
    context = Context(*engineer_);
    expect(reprocessing_->CancelJob(context.get(), cancel, &job), grpc::StatusCode::INVALID_ARGUMENT,
           "job_id");
    fleet::v1::ListJobsRequest jobs;
    jobs.set_state("sleeping");
    fleet::v1::ListJobsResponse listed;
    context = Context(*engineer_);
    expect(reprocessing_->ListJobs(context.get(), jobs, &listed), grpc::StatusCode::INVALID_ARGUMENT,
           "state");
  }
  {
    fleet::v1::SetCredentialRequest request;
    request.set_principal("superuser:eve");
    fleet::v1::SetCredentialResponse response;
    auto context = Context(FleetdProcess::AdminToken());
    expect(admin_->SetCredential(context.get(), request, &response), grpc::StatusCode::INVALID_ARGUMENT,
           "principal");
    fleet::v1::TrainModelRequest train;
    train.set_name("protrusion");
    train.set_classifier("neural_net");
    fleet::v1::TrainModelResponse trained;
    context = Context(FleetdProcess::AdminToken());
    expect(models_->TrainModel(context.get(), train, &trained), grpc::StatusCode::INVALID_ARGUMENT,
           "classifier");
    fleet::v1::ActivateModelRequest activate;
    activate.set_name("protrusion");
    activate.set_version(99);
    fleet::v1::Model model;
    context = Context(FleetdProcess::AdminToken());
    expect(models_->ActivateModel(context.get(), activate, &model), grpc::StatusCode::NOT_FOUND, "version");
    fleet::v1::ListModelsRequest list;
    fleet::v1::ListModelsResponse listed;
    context = Context(*engineer_);
    expect(models_->ListModels(context.get(), list, &listed), grpc::StatusCode::INVALID_ARGUMENT, "name");
  }
}

TEST_F(FleetdTest, MetricsHealthzAndGrpcHealth) {
  UploadAll();
  std::string body;
  EXPECT_EQ(HttpGet(server_->http_address(), "/healthz", &body), 200);
  EXPECT_EQ(body, "ok\n");
  EXPECT_EQ(HttpGet(server_->http_address(), "/nope", &body), 401);  // no route enumeration without a token
  EXPECT_EQ(HttpGet(server_->http_address(), "/nope", &body, *engineer_), 404);
  EXPECT_EQ(HttpGet(server_->http_address(), "/metrics", &body), 401);
  ASSERT_EQ(HttpGet(server_->http_address(), "/metrics", &body, *engineer_), 200);
  for (const char* series :
       {"fleetd_ingest_runs_total{outcome=\"stored\"}", "fleetd_ingest_bytes_total",
        "fleetd_ingest_events_total", "fleetd_rpc_latency_seconds_bucket{method=\"Ingest/UploadRun\"",
        "fleetd_job_queue_depth{state=\"queued\"}",
        "fleetd_rpc_total{method=\"Ingest/UploadRun\",code=\"OK\"}"}) {
    EXPECT_NE(body.find(series), std::string::npos) << series;
  }
  auto channel = server_->Channel();
  EXPECT_EQ(HealthStatus(channel), 1) << "grpc.health.v1: SERVING";
}

// A limit a run can never fit is INVALID_ARGUMENT (not retried); a message over gRPC's size limit is gRPC's own
// RESOURCE_EXHAUSTED; the rate limit is RESOURCE_EXHAUSTED (retry later). A separate fleetd with small limits.
TEST(FleetdLimitsTest, EventsMessageSizeAndRateLimits) {
  FleetdProcess server({"--max-events-per-run", "100", "--max-message-bytes", "20000", "--rate-limit", "1",
                        "--rate-burst", "6"});
  ASSERT_THAT(server, IsOk());
  auto channel = server.Channel();
  auto ingest = fleet::v1::Ingest::NewStub(channel);
  const RunFile& run = SimulatedRuns()[0];
  UploadRunResponse response;
  grpc::Status status = Upload(*ingest, FleetdProcess::AdminToken(), run, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("event_count"), std::string::npos) << status.error_message();
  // One message above the size limit (the whole run in one chunk), header count not announced.
  RunFile huge = run;
  huge.mutable_header()->set_event_count(0);
  UploadOptions one_chunk;
  one_chunk.events_per_chunk = 1 << 30;
  status = Upload(*ingest, FleetdProcess::AdminToken(), huge, &response, one_chunk);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  // Rate limit: a burst of 6, then refusals.
  auto queries = fleet::v1::Queries::NewStub(channel);
  int exhausted = 0;
  for (int i = 0; i < 12; ++i) {
    fleet::v1::ListRunsRequest request;
    fleet::v1::ListRunsResponse listed;
    auto context = Context(FleetdProcess::AdminToken());
    if (queries->ListRuns(context.get(), request, &listed).error_code() ==
        grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++exhausted;
    }
  }
  EXPECT_GE(exhausted, 3);
  EXPECT_EQ(server.Stop(), 0);
}

// SIGTERM with work in flight: fleetd finishes or hands back its jobs and exits 0; a new fleetd on the same
// database completes them.
TEST(FleetdShutdownTest, SigtermMidWorkThenRestartFinishes) {
  auto server =
      std::make_unique<FleetdProcess>(std::vector<std::string>{"--workers", "1", "--lease-seconds", "4"});
  ASSERT_TRUE(server->ok());
  const std::filesystem::path directory = server->directory();
  {
    auto ingest = fleet::v1::Ingest::NewStub(server->Channel());
    for (const RunFile& run : SimulatedRuns()) {
      UploadRunResponse response;
      ASSERT_THAT(Upload(*ingest, FleetdProcess::AdminToken(), run, &response), IsOk());
    }
  }
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(server->Stop(), 0);
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(15));
  // Keep the database: restart on it (fresh process object over the same file).
  const std::string db = "sqlite:" + (directory / "fleet.db").string();
  FleetdProcess second({"--db", db});
  ASSERT_THAT(second, IsOk());
  auto queries = fleet::v1::Queries::NewStub(second.Channel());
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  int reported = 0;
  while (std::chrono::steady_clock::now() < until) {
    reported = 0;
    for (const RunFile& run : SimulatedRuns()) {
      fleet::v1::GetRunReportRequest request;
      request.set_run_id(run.header().run_id());
      fleet::v1::GetRunReportResponse response;
      auto context = Context(FleetdProcess::AdminToken());
      if (queries->GetRunReport(context.get(), request, &response).ok()) ++reported;
    }
    if (reported == static_cast<int>(SimulatedRuns().size())) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_EQ(reported, static_cast<int>(SimulatedRuns().size()));
  EXPECT_EQ(second.Stop(), 0);
}

// One query service behind both transports (issue 20): the same slice asked over gRPC and over HTTP gives the
// same numbers — totals, the day keys and their counts, the comparison's counts and its ranking and scores.
// Runs after ReprocessWithSecondParameterSetAndCompare, which stored the second set's reports.
TEST_F(FleetdTest, GrpcAndHttpAnswerTheSameNumbersForTheSameSlice) {
  UploadAll();
  for (const RunFile& run : SimulatedRuns())
    ASSERT_THAT(WaitForReport(run.header().run_id(), "", nullptr), IsOk());
  fleet::v1::GetFleetStatisticsRequest request;
  request.mutable_filter()->set_parameter_set("default");
  request.set_group_by(fleet::v1::GROUP_BY_DAY);
  fleet::v1::GetFleetStatisticsResponse grpc_stats;
  auto context = Context(*engineer_);
  ASSERT_THAT(queries_->GetFleetStatistics(context.get(), request, &grpc_stats), IsOk());
  std::string body;
  ASSERT_EQ(HttpGet(server_->http_address(), "/api/stats?parameter_set=default", &body, *engineer_), 200)
      << body;
  const auto http_stats = nlohmann::json::parse(body);
  const auto& total = http_stats["total"];
  EXPECT_GT(grpc_stats.total().reports(), 0);
  EXPECT_EQ(total["reports"].get<std::int64_t>(), grpc_stats.total().reports());
  EXPECT_EQ(total["robots"].get<std::int64_t>(), grpc_stats.total().robots());
  EXPECT_EQ(total["recovery_created"].get<std::int64_t>(), grpc_stats.total().recovery_created());
  EXPECT_EQ(total["views_ambiguous"].get<std::int64_t>(), grpc_stats.total().views_ambiguous());
  EXPECT_DOUBLE_EQ(total["ambiguous_view_share"].get<double>(), grpc_stats.total().ambiguous_view_share());
  ASSERT_EQ(http_stats["by_day"].size(), static_cast<std::size_t>(grpc_stats.groups_size()));
  for (int i = 0; i < grpc_stats.groups_size(); ++i) {
    EXPECT_EQ(http_stats["by_day"][i]["key"].get<std::string>(), grpc_stats.groups(i).key());
    EXPECT_EQ(http_stats["by_day"][i]["reports"].get<std::int64_t>(),
              grpc_stats.groups(i).figures().reports());
    EXPECT_EQ(http_stats["by_day"][i]["robots"].get<std::int64_t>(), grpc_stats.groups(i).figures().robots());
  }

  fleet::v1::CompareParameterSetsRequest compare;
  compare.set_set_a("default");
  compare.set_set_b("strict-merge");
  compare.set_top(10);
  fleet::v1::CompareParameterSetsResponse grpc_compare;
  context = Context(*engineer_);
  const grpc::Status status = queries_->CompareParameterSets(context.get(), compare, &grpc_compare);
  ASSERT_THAT(status, IsOk());
  ASSERT_EQ(
      HttpGet(server_->http_address(), "/api/compare?a=default&b=strict-merge&limit=10", &body, *engineer_),
      200)
      << body;
  const auto http_compare = nlohmann::json::parse(body);
  EXPECT_GT(grpc_compare.runs_compared(), 0);
  EXPECT_EQ(http_compare["runs_compared"].get<std::int64_t>(), grpc_compare.runs_compared());
  EXPECT_EQ(http_compare["runs_changed"].get<std::int64_t>(), grpc_compare.runs_changed());
  EXPECT_EQ(http_compare["stats_b"]["reports"].get<std::int64_t>(), grpc_compare.b().reports());
  ASSERT_EQ(http_compare["changed_most"].size(), static_cast<std::size_t>(grpc_compare.most_changed_size()));
  for (int i = 0; i < grpc_compare.most_changed_size(); ++i) {
    const auto& row = http_compare["changed_most"][i];
    EXPECT_EQ(row["run_id"].get<std::string>(), grpc_compare.most_changed(i).run_id()) << "rank " << i;
    EXPECT_EQ(row["robot_id"].get<std::string>(), grpc_compare.most_changed(i).robot_id()) << "rank " << i;
    EXPECT_DOUBLE_EQ(row["score"].get<double>(), grpc_compare.most_changed(i).change()) << "rank " << i;
  }
}

// The robots page is paged by robot id and summarises each history as the robot's own history page does.
TEST_F(FleetdTest, TheRobotsPagePagesByRobotAndAgreesWithEachHistory) {
  UploadAll();
  std::set<std::string> uploaded;
  for (const RunFile& run : SimulatedRuns()) uploaded.insert(run.header().robot_id());
  ASSERT_GE(uploaded.size(), 2u);
  std::string body;
  std::vector<std::string> listed;
  std::int64_t versions = 0;
  std::string after;
  for (int page = 0; page < 100; ++page) {
    const std::string path = "/api/robots?limit=1" + (after.empty() ? "" : "&after=" + after);
    ASSERT_EQ(HttpGet(server_->http_address(), path, &body, *engineer_), 200) << body;
    const auto answer = nlohmann::json::parse(body);
    ASSERT_EQ(answer["robots"].size(), 1u) << body;
    const auto& robot = answer["robots"][0];
    const std::string id = robot["robot_id"].get<std::string>();
    listed.push_back(id);
    versions += robot["versions"].get<std::int64_t>();
    // The row agrees with the robot's own history and with its one-robot summary.
    ASSERT_EQ(HttpGet(server_->http_address(), "/api/robots/" + id + "/maps", &body, *engineer_), 200)
        << body;
    const auto history = nlohmann::json::parse(body);
    EXPECT_EQ(robot["versions"].get<std::size_t>(), history["versions"].size()) << id;
    EXPECT_EQ(robot["current_version"].get<std::int64_t>(), history["current_version"].get<std::int64_t>());
    ASSERT_EQ(HttpGet(server_->http_address(), "/api/robots/" + id, &body, *engineer_), 200) << body;
    EXPECT_EQ(nlohmann::json::parse(body), robot);
    EXPECT_EQ(answer["total"].get<std::size_t>(), uploaded.size());
    if (answer["next"].is_null()) break;
    after = answer["next"]["after"].get<std::string>();
    EXPECT_EQ(after, id);
  }
  EXPECT_EQ(std::set<std::string>(listed.begin(), listed.end()), uploaded);
  EXPECT_EQ(listed.size(), uploaded.size()) << "each robot on exactly one page";
  EXPECT_TRUE(std::is_sorted(listed.begin(), listed.end()));
  EXPECT_GE(versions, static_cast<std::int64_t>(uploaded.size())) << "every robot's uploads made versions";

  // A robot reads its own row, never the fleet's; bad parameters are named.
  const std::string own = *uploaded.begin();
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/robots/" + own, &body, RobotToken(own)), 200) << body;
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/robots?limit=5", &body, RobotToken(own)), 403) << body;
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/robots/no-such-robot", &body, *engineer_), 404) << body;
  for (const std::string query : {"limit=0", "limit=1001", "limit=x", "pending=yes"}) {
    EXPECT_EQ(HttpGet(server_->http_address(), "/api/robots?" + query, &body, *engineer_), 400) << query;
    EXPECT_NE(body.find(query.substr(0, query.find('='))), std::string::npos) << body;
  }

  // Maps.ListRobots (fleetctl maps robots) pages the same rows.
  auto maps = fleet::v1::Maps::NewStub(server_->Channel());
  std::vector<std::string> over_grpc;
  fleet::v1::ListRobotsRequest request;
  request.set_page_size(1);
  for (int page = 0; page < 100; ++page) {
    fleet::v1::ListRobotsResponse response;
    auto context = Context(*engineer_);
    ASSERT_THAT(maps->ListRobots(context.get(), request, &response), IsOk());
    ASSERT_EQ(response.robots_size(), 1);
    EXPECT_EQ(response.total(), static_cast<std::int64_t>(uploaded.size()));
    over_grpc.push_back(response.robots(0).robot_id());
    ASSERT_EQ(HttpGet(server_->http_address(), "/api/robots/" + over_grpc.back(), &body, *engineer_), 200);
    const auto row = nlohmann::json::parse(body);
    EXPECT_EQ(response.robots(0).versions(), row["versions"].get<std::int64_t>());
    EXPECT_EQ(response.robots(0).current_version(), row["current_version"].get<std::int64_t>());
    if (response.next_after_robot_id().empty()) break;
    request.set_after_robot_id(response.next_after_robot_id());
  }
  EXPECT_EQ(over_grpc, listed);
  fleet::v1::ListRobotsResponse refused;
  auto context = Context(RobotToken(own));
  EXPECT_EQ(maps->ListRobots(context.get(), fleet::v1::ListRobotsRequest(), &refused).error_code(),
            grpc::StatusCode::PERMISSION_DENIED)
      << "a robot does not list the fleet";
  request.set_page_size(1001);
  context = Context(*engineer_);
  const grpc::Status too_large = maps->ListRobots(context.get(), request, &refused);
  EXPECT_EQ(too_large.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(too_large.error_message().find("page_size"), std::string::npos) << too_large.error_message();
}

}  // namespace
}  // namespace fleetd_test
