// polyportd between DDS peer programs (tests/dds_peers), each vendor on the side that
// tests/dds_e2e gives the other: there Cyclone DDS feeds polyport and Fast DDS is fed, and a
// Cyclone client and a Fast DDS server take part in services. Here the Fast DDS model decodes
// into an in-process component (and counts a sample that does not decode), the Cyclone model
// encodes, a Fast DDS client calls an in-process provider, an in-process caller calls a Cyclone
// server, and a Fast DDS publisher restarts. So each model's reading, writing, client-side and
// server-side paths run against a real application of its vendor.
//
// Every process is a child of the test, written to files in the test's own directory; every
// wait is for a line in a child's output or a file, with a deadline. Each test has its own
// pair of DDS domains (200..209) so that tests running in parallel do not hear each other.
#include "e2e_scenarios.hpp"

namespace polyport {
namespace {

using namespace test;
using namespace std::chrono_literals;

// The same harness; the name says which half of the matrix a case belongs to.
class DdsVendorMirror : public DdsEndToEnd {};

// Fast DDS publishes on domain B, Cyclone subscribes on domain A.
Route fastdds_to_cyclone(int domain_a, int domain_b) {
  return Route{domain_a, domain_b, FASTDDS_PEER, domain_b, "pose_back", CYCLONE_PEER, domain_a, "pose_back"};
}

TEST_F(DdsVendorMirror, FastddsPublisherThroughAnInProcessComponentToACycloneSubscriber) {
  relay_scenario(*this, "relay_from_fastdds_app.xml", fastdds_to_cyclone(200, 201), "fast.pose_back -> relay.in",
                 "relay.out -> cyclone.pose_back");
}

TEST_F(DdsVendorMirror, UndecodableSampleReachingTheFastddsModelIsCountedAndTheConnectionGoesOn) {
  // A Cyclone application of bad_pose.idl in the Fast DDS model's domain (the two vendors
  // interoperate on the wire).
  undecodable_scenario(*this, "relay_from_fastdds_app.xml", fastdds_to_cyclone(202, 203),
                       "fast.pose_back -> relay.in");
}

TEST_F(DdsVendorMirror, FastddsPublisherThatRestartsIsPickedUpAgain) {
  // SIGTERM: the application deletes its participant, so no shared-memory segment of a killed
  // Fast DDS process is left behind on the test machine (e2e_test.cpp kills a Cyclone one).
  restart_scenario(*this, "cross_vendor_app.xml", fastdds_to_cyclone(204, 205), SIGTERM, 0,
                   "fast.pose_back -> cyclone.pose_back");
}

TEST_F(DdsVendorMirror, FastddsClientCallsAnInProcessService) {
  client_scenario(*this, "fastdds_client_app.xml", 206, 207, FASTDDS_PEER, 207);
}

TEST_F(DdsVendorMirror, InProcessCallerCallsACycloneServerAndTimesOutWithoutOne) {
  server_scenario(*this, "cyclone_server_app.xml", 208, 209, CYCLONE_PEER, 208);
}

}  // namespace
}  // namespace polyport
