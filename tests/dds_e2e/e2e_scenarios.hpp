// The end-to-end cases that run once per direction across the two vendors (e2e_test.cpp one
// way, vendor_mirror_test.cpp the other): each is a function of the route a sample takes.
#pragma once

#include <csignal>
#include <string>

#include "e2e_fixture.hpp"

namespace polyport::test {

// Where a publisher peer and a subscriber peer sit; the template's @A@ / @B@ domains are
// `domain_a` / `domain_b`.
struct Route {
  int domain_a = 0;
  int domain_b = 0;
  const char* publisher = nullptr;  // peer program
  int pub_domain = 0;
  const char* pub_topic = nullptr;
  const char* subscriber = nullptr;  // peer program
  int sub_domain = 0;
  const char* sub_topic = nullptr;
};

inline std::string text(int number) { return std::to_string(number); }

// publisher -> polyport decodes into the in-process PoseRelay (connection `in`) -> the relay's
// output is encoded (connection `out`) for the subscriber; every field checked at the end.
// Neither connection drops anything: the engine starts the writing side before the reading one.
inline void relay_scenario(DdsEndToEnd& t, const std::string& app, const Route& r, const std::string& in_name,
                           const std::string& out_name) {
  auto polyportd = t.daemon(t.profiles(app, r.domain_a, r.domain_b));
  auto sub = t.peer(r.subscriber, "sub", {"sub", text(r.sub_domain), r.sub_topic, "6", "60"});
  auto pub = t.peer(r.publisher, "pub", {"pub", text(r.pub_domain), r.pub_topic, kForever, "5"});
  ASSERT_EQ(sub->wait(60s), 0) << "subscriber: " << sub->errors();
  const auto got = poses(*sub);
  ASSERT_EQ(got.size(), 6u);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);

  pub.reset();
  const Json stats = t.stop(*polyportd);
  const Json* in = connection(stats, in_name);
  const Json* out = connection(stats, out_name);
  ASSERT_TRUE(in && out);
  EXPECT_EQ((*in)["conversion"], "xcdr1 -> flat");
  EXPECT_EQ((*out)["conversion"], "flat -> xcdr1");
  EXPECT_GE((*in)["delivered"].get<int>(), 6);
  EXPECT_GE((*out)["delivered"].get<int>(), 6);
  EXPECT_EQ((*in)["dropped"], 0) << in->dump(2);
  EXPECT_EQ((*out)["dropped"], 0) << out->dump(2);
}

// As relay_scenario, with a Cyclone application of bad_pose.idl (same type name, one octet)
// publishing two samples on the publisher's topic in between: connection `in` counts exactly
// two decode errors, and good samples arrive before and after.
inline void undecodable_scenario(DdsEndToEnd& t, const std::string& app, const Route& r, const std::string& in_name) {
  auto polyportd = t.daemon(t.profiles(app, r.domain_a, r.domain_b));
  auto sub = t.peer(r.subscriber, "sub", {"sub", text(r.sub_domain), r.sub_topic, "100000", "60"});
  auto good = t.peer(r.publisher, "good", {"pub", text(r.pub_domain), r.pub_topic, kForever, "5"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 3; })) << "nothing relayed";
  // The bad peer exits once polyport's reader has acknowledged both samples.
  auto bad = t.peer(CYCLONE_BAD_PEER, "bad", {"pub", text(r.pub_domain), r.pub_topic, "2", "5"});
  ASSERT_EQ(bad->wait(60s), 0) << bad->errors();
  const std::size_t before = poses(*sub).size();
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= before + 3; })) << "nothing relayed after";
  good.reset();
  const auto got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose, kRelayOffset);
  expect_increasing(got);
  sub.reset();

  const Json stats = t.stop(*polyportd);
  const Json* in = connection(stats, in_name);
  ASSERT_TRUE(in);
  EXPECT_EQ((*in)["dropped_by_reason"]["decode_error"], 2) << in->dump(2);
  EXPECT_EQ((*in)["dropped"], 2) << in->dump(2);
  EXPECT_EQ((*in)["delivered"].get<int>() + 2, (*in)["received"].get<int>()) << in->dump(2);
  // The DDS reader's own count, kept after stop for the final statistics: every sample it
  // handed on (the undecodable ones too: polyport's codec refused them, not the SDK).
  const Json* topic = source_topic(stats, *in);
  ASSERT_TRUE(topic);
  EXPECT_EQ((*topic)["received"], (*in)["received"]) << topic->dump(2);
  EXPECT_EQ((*topic)["refused"], 0) << topic->dump(2);
}

// A publisher ends (`stop_signal`; `exit_status` is what its process then returns) and a new
// process of it, numbering from 1000, is picked up without restarting polyport; `passthrough`
// is the connection between them, which drops nothing.
inline void restart_scenario(DdsEndToEnd& t, const std::string& app, const Route& r, int stop_signal, int exit_status,
                             const std::string& passthrough) {
  auto polyportd = t.daemon(t.profiles(app, r.domain_a, r.domain_b));
  auto sub = t.peer(r.subscriber, "sub", {"sub", text(r.sub_domain), r.sub_topic, "100000", "60"});
  auto first = t.peer(r.publisher, "first_run", {"pub", text(r.pub_domain), r.pub_topic, kForever, "5", "0"});
  ASSERT_TRUE(eventually([&] { return poses(*sub).size() >= 2; })) << "first run not forwarded";
  first->signal(stop_signal);
  EXPECT_EQ(first->wait(20s), exit_status) << first->errors();
  auto second = t.peer(r.publisher, "second_run", {"pub", text(r.pub_domain), r.pub_topic, kForever, "5", "1000"});
  ASSERT_TRUE(eventually([&] {
    const auto got = poses(*sub);
    return !got.empty() && got.back()["id"].get<int>() >= peer_values::id(1002);
  })) << "the restarted publisher was not picked up";
  second.reset();
  const auto got = poses(*sub);
  for (const Json& pose : got) expect_pose(pose);
  expect_increasing(got);
  sub.reset();
  const Json stats = t.stop(*polyportd);
  const Json* link = connection(stats, passthrough);
  ASSERT_TRUE(link);
  EXPECT_EQ((*link)["dropped"], 0) << link->dump(2) << "\npolyportd:\n" << polyportd->errors();
}

// A DDS client (`program` on `domain`) calls add(i, 0.5) five times on the in-process PeerAdder.
inline void client_scenario(DdsEndToEnd& t, const std::string& app, int domain_a, int domain_b, const char* program,
                            int domain) {
  auto polyportd = t.daemon(t.profiles(app, domain_a, domain_b));
  auto client = t.peer(program, "client", {"call", text(domain), "calc", "5", "5000"});
  ASSERT_EQ(client->wait(90s), 0) << client->errors();
  int requests = 0;  // the client resends a request whose reply it missed (kCallAttempts)
  EXPECT_EQ(checked_replies(*client, requests), 5);
  const Json stats = t.stop(*polyportd);
  ASSERT_EQ(stats["services"].size(), 1u);
  // Every answered call was served, and nothing was served that the client did not send. Not
  // every request sent need arrive: the client's writer can see polyport's reader matched
  // before that reader has matched the writer, and a volatile reader then drops the sample
  // (seen under ASan: six requests, five served); the client resends it.
  const int served = stats["services"][0]["ok"].get<int>();
  EXPECT_GE(served, 5) << stats["services"].dump(2);
  EXPECT_LE(served, requests) << stats["services"].dump(2);
}

// The in-process PeerCaller calls a DDS server (`program` on `domain`): a silent one (every
// call ends with the bridge's 150 ms call timeout, nothing is published), then an answering
// one. It answers 20 requests and the test needs 5 back, so that one reply slower than the
// call timeout on a busy machine decides nothing.
inline void server_scenario(DdsEndToEnd& t, const std::string& app, int domain_a, int domain_b, const char* program,
                            int domain) {
  const fs::path trace = t.dir() / "sums.jsonl";
  auto polyportd =
      t.daemon(t.profiles(app, domain_a, domain_b), {"--trace", "caller.sums", "--trace-file", trace.string()});
  auto silent = t.peer(program, "silent", {"serve", text(domain), "calc", "3", "silent"});
  ASSERT_EQ(silent->wait(60s), 0) << silent->errors();
  EXPECT_TRUE(traced_sums(trace).empty()) << "a sum without an answering server";
  auto server = t.peer(program, "server", {"serve", text(domain), "calc", "20"});
  ASSERT_EQ(server->wait(60s), 0) << server->errors();
  ASSERT_TRUE(eventually([&] { return traced_sums(trace).size() >= 5; }, 20s)) << "no sums traced";
  const Json stats = t.stop(*polyportd);
  const auto sums = traced_sums(trace);
  for (double sum : sums) EXPECT_EQ(sum - std::floor(sum), 0.5) << sum;  // n + 0.5 for some n
  ASSERT_EQ(stats["services"].size(), 1u);
  const Json& calls = stats["services"][0];
  EXPECT_GE(calls["timeouts"].get<int>(), 3) << calls.dump(2);              // at least the silent server's
  EXPECT_EQ(calls["ok"].get<std::size_t>(), sums.size()) << calls.dump(2);  // every answer published
}

}  // namespace polyport::test
