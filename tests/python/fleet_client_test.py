#!/usr/bin/python3
"""The fleet.v1 contract from Python (Debian's python3-grpcio): stubs are generated from proto/ at test time
into a temp dir, a real fleetd runs on loopback, and a hand-built run goes through upload, duplicate upload,
bad input, auth failure, analysis and queries.

Stubs come from the system protoc with Debian's grpc_python_plugin: the protoc bundled in Debian's
python3-grpc-tools (3.5.1) predates proto3 `optional`, which our protos use; grpc_tools is the fallback.

    /usr/bin/python3 fleet_client_test.py FLEETD_BINARY PROTO_DIR [PROTOC]
"""
import atexit
import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

FLEETD, PROTO_DIR = sys.argv[1], sys.argv[2]
PROTOC = sys.argv[3] if len(sys.argv) > 3 else "/usr/bin/protoc"
ADMIN = "admin:root." + secrets.token_hex(32)

import grpc  # noqa: E402

STUBS = tempfile.mkdtemp(prefix="fleet-py-stubs-")
atexit.register(shutil.rmtree, STUBS, ignore_errors=True)
PROTOS = ["fleet/v1/telemetry.proto", "fleet/v1/report.proto", "fleet/v1/maps.proto", "fleet/v1/service.proto"]
if os.path.exists(PROTOC) and os.path.exists("/usr/bin/grpc_python_plugin"):
    subprocess.run([PROTOC, "-I" + PROTO_DIR, "--python_out=" + STUBS, "--grpc_python_out=" + STUBS,
                    "--plugin=protoc-gen-grpc_python=/usr/bin/grpc_python_plugin"] + PROTOS, check=True)
else:
    from grpc_tools import protoc
    if protoc.main(["protoc", "-I" + PROTO_DIR, "--python_out=" + STUBS, "--grpc_python_out=" + STUBS] + PROTOS) != 0:
        raise SystemExit("grpc_tools.protoc failed")
sys.path.insert(0, STUBS)
from fleet.v1 import service_pb2, service_pb2_grpc, telemetry_pb2  # noqa: E402

COVARIANCE = [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4]


def make_run(run_id, robot_id="py-robot", nodes=20):
    header = telemetry_pb2.RunHeader(format_version=1, robot_id=robot_id, run_id=run_id, firmware="py-1.0",
                                     robot_model="py-model", started_at=1767225600.0, ended_at=1767225700.0,
                                     event_count=nodes)
    events = []
    snapshot = telemetry_pb2.MapSnapshot(format_version=1)
    for i in range(nodes):
        odometry = telemetry_pb2.Odometry(increment=telemetry_pb2.Pose2(x=0.3 if i else 0.0), covariance=COVARIANCE)
        events.append(telemetry_pb2.Event(time=float(i), odometry=odometry))
        snapshot.nodes.add(id=i, pose=telemetry_pb2.Pose2(x=0.3 * i), time=float(i), odometer=0.3 * i)
    return header, events, snapshot


def stream(header, events, snapshot, chunk=7):
    yield service_pb2.UploadRunRequest(header=header)
    for i in range(0, len(events), chunk):
        yield service_pb2.UploadRunRequest(events=telemetry_pb2.EventChunk(events=events[i:i + chunk]))
    yield service_pb2.UploadRunRequest(child_snapshot=snapshot)


class FleetClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="fleet-py-")
        env = dict(os.environ, FLEETD_BOOTSTRAP_ADMIN_TOKEN=ADMIN)
        cls.log = open(os.path.join(cls.dir, "fleetd.log"), "w")
        cls.proc = subprocess.Popen([FLEETD, "--db", "sqlite:" + os.path.join(cls.dir, "fleet.db"), "--listen",
                                     "127.0.0.1:0", "--http", "127.0.0.1:0", "--workers", "1"],
                                    stdout=subprocess.PIPE, stderr=cls.log, env=env, text=True)
        cls.addresses = json.loads(cls.proc.stdout.readline())
        cls.channel = grpc.insecure_channel(cls.addresses["grpc"])
        cls.ingest = service_pb2_grpc.IngestStub(cls.channel)
        cls.queries = service_pb2_grpc.QueriesStub(cls.channel)
        cls.admin = service_pb2_grpc.AdminStub(cls.channel)
        cls.robot = cls.token("robot:py-robot")
        cls.engineer = cls.token("engineer:py")

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        cls.proc.send_signal(signal.SIGTERM)
        assert cls.proc.wait(timeout=30) == 0, "fleetd exits 0 on SIGTERM"
        cls.log.close()
        shutil.rmtree(cls.dir, ignore_errors=True)

    @classmethod
    def token(cls, principal):
        response = cls.admin.SetCredential(service_pb2.SetCredentialRequest(principal=principal),
                                           metadata=[("authorization", "Bearer " + ADMIN)], timeout=30)
        return response.token

    def auth(self, token):
        return [("authorization", "Bearer " + token)]

    def test_upload_duplicate_report_and_stats(self):
        header, events, snapshot = make_run("py-run-1")
        response = self.ingest.UploadRun(stream(header, events, snapshot), metadata=self.auth(self.robot), timeout=30)
        self.assertEqual(response.run_id, "py-run-1")
        self.assertFalse(response.already_present)
        self.assertEqual(response.events_stored, len(events))
        again = self.ingest.UploadRun(stream(header, events, snapshot, chunk=3), metadata=self.auth(self.robot),
                                      timeout=30)
        self.assertTrue(again.already_present)
        deadline = time.time() + 60
        while True:
            try:
                report = self.queries.GetRunReport(service_pb2.GetRunReportRequest(run_id="py-run-1"),
                                                   metadata=self.auth(self.engineer), timeout=10).report
                break
            except grpc.RpcError as error:
                self.assertEqual(error.code(), grpc.StatusCode.NOT_FOUND, error.details())
                self.assertLess(time.time(), deadline, "no report within 60 s")
                time.sleep(0.1)
        self.assertEqual(report.run_id, "py-run-1")
        self.assertEqual(report.parameter_set, "default")
        self.assertEqual(report.divergence.rerun_nodes, len(events))
        runs = self.queries.ListRuns(service_pb2.ListRunsRequest(filter=service_pb2.RunFilter(robot_id="py-robot")),
                                     metadata=self.auth(self.engineer), timeout=10)
        self.assertEqual([run.run_id for run in runs.runs], ["py-run-1"])
        stats = self.queries.GetFleetStatistics(service_pb2.GetFleetStatisticsRequest(group_by=service_pb2.GROUP_BY_DAY),
                                                metadata=self.auth(self.engineer), timeout=10)
        self.assertEqual(stats.total.reports, 1)
        self.assertEqual(stats.groups[0].key, "2026-01-01")

    def test_bad_input_names_the_field(self):
        header, events, snapshot = make_run("py-bad")
        del events[3].odometry.covariance[-1]
        with self.assertRaises(grpc.RpcError) as caught:
            self.ingest.UploadRun(stream(header, events, snapshot), metadata=self.auth(self.robot), timeout=30)
        self.assertEqual(caught.exception.code(), grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("events[3].odometry.covariance", caught.exception.details())

    def test_auth_failures(self):
        header, events, snapshot = make_run("py-auth", robot_id="someone-else")
        with self.assertRaises(grpc.RpcError) as caught:
            self.ingest.UploadRun(stream(header, events, snapshot), timeout=30)
        self.assertEqual(caught.exception.code(), grpc.StatusCode.UNAUTHENTICATED)
        with self.assertRaises(grpc.RpcError) as caught:
            self.ingest.UploadRun(stream(header, events, snapshot), metadata=self.auth(self.robot), timeout=30)
        self.assertEqual(caught.exception.code(), grpc.StatusCode.PERMISSION_DENIED)
        self.assertIn("header.robot_id", caught.exception.details())
        with self.assertRaises(grpc.RpcError) as caught:
            self.queries.ListRuns(service_pb2.ListRunsRequest(), metadata=self.auth(self.robot), timeout=10)
        self.assertEqual(caught.exception.code(), grpc.StatusCode.PERMISSION_DENIED)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
