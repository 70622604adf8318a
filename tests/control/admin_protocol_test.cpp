// The admin socket's request parser, reply builders and line framing (docs/CONTROL.md).
#include <gtest/gtest.h>

#include "admin_protocol.hpp"

namespace polyport::admin {
namespace {

using nlohmann::json;

std::optional<Request> parse(const std::string& line, ParseError& error) { return parse_request(line, error); }

TEST(AdminRequest, ParsesEveryCommand) {
  ParseError error;
  auto hello = parse(R"({"v":1,"id":7,"cmd":"hello"})", error);
  ASSERT_TRUE(hello) << error.message;
  EXPECT_EQ(hello->command, Command::hello);
  EXPECT_EQ(hello->id, 7);
  for (const char* name : {"list", "stats"}) {
    auto r = parse(std::string(R"({"v":1,"id":"a","cmd":")") + name + "\"}", error);
    ASSERT_TRUE(r) << name << ": " << error.message;
    EXPECT_EQ(to_string(r->command), name);
    EXPECT_EQ(r->id, "a");
  }
  for (const char* name : {"activate", "deactivate", "reset", "get"}) {
    auto r = parse(std::string(R"({"v":1,"cmd":")") + name + R"(","component":"Control"})", error);
    ASSERT_TRUE(r) << name << ": " << error.message;
    EXPECT_EQ(to_string(r->command), name);
    EXPECT_EQ(r->component, "Control");
    EXPECT_TRUE(r->id.is_null());
  }
}

TEST(AdminRequest, RefusesWithAReasonAndKeepsTheId) {
  struct Case {
    const char* line;
    const char* code;
    const char* says;
  };
  for (const Case& c : {Case{"garbage", kBadRequest, "not JSON"}, Case{"[1,2]", kBadRequest, "JSON object"},
                        Case{R"({"id":3,"cmd":"hello"})", kBadRequest, "\"v\""},
                        Case{R"({"v":2,"id":3,"cmd":"hello"})", kBadRequest, "version 2 is not supported"},
                        Case{R"({"v":1,"id":3})", kBadRequest, "\"cmd\""},
                        Case{R"({"v":1,"id":3,"cmd":"restart"})", kUnknownCommand, "unknown command 'restart'"},
                        Case{R"({"v":1,"id":3,"cmd":"activate"})", kBadRequest, "needs \"component\""},
                        Case{R"({"v":1,"id":3,"cmd":"activate","component":""})", kBadRequest, "\"component\" must be a non-empty string"},
                        Case{R"({"v":1,"id":3,"cmd":"list","component":"X"})", kBadRequest, "takes no"},
                        Case{R"({"v":1,"id":[3],"cmd":"list"})", kBadRequest, "\"id\""}}) {
    ParseError error;
    EXPECT_FALSE(parse(c.line, error)) << c.line;
    EXPECT_EQ(error.code, c.code) << c.line;
    EXPECT_NE(error.message.find(c.says), std::string::npos) << c.line << ": " << error.message;
    if (std::string(c.line).find("\"id\":3") != std::string::npos) {
      EXPECT_EQ(error.id, 3) << c.line;
    }
  }
}

TEST(AdminRequest, ParsesATraceAndItsStreamedLines) {
  ParseError error;
  auto trace = parse(R"({"v":1,"id":5,"cmd":"trace","port":"Joystick.reference","count":10,"duration":2.5})", error);
  ASSERT_TRUE(trace) << error.message;
  EXPECT_EQ(trace->command, Command::trace);
  EXPECT_EQ(trace->port, "Joystick.reference");
  EXPECT_EQ(trace->count, 10);
  EXPECT_EQ(trace->duration_s, 2.5);
  auto endless = parse(R"({"v":1,"cmd":"trace","port":"HW.wheel_speeds"})", error);
  ASSERT_TRUE(endless) << error.message;
  EXPECT_FALSE(endless->count);
  EXPECT_FALSE(endless->duration_s);
  // Round trip of what polyportctl sends.
  const std::string line = request_line(*trace);
  auto back = parse(line.substr(0, line.size() - 1), error);
  ASSERT_TRUE(back) << error.message;
  EXPECT_EQ(back->port, trace->port);
  EXPECT_EQ(back->count, trace->count);
  EXPECT_EQ(back->duration_s, trace->duration_s);
  for (const auto& [bad, says] : std::vector<std::pair<const char*, const char*>>{
           {R"({"v":1,"cmd":"trace"})", "needs \"port\""},
           {R"({"v":1,"cmd":"trace","port":"Joystick"})", "COMPONENT.PORT"},
           {R"({"v":1,"cmd":"trace","port":"J.r","count":0})", "\"count\" must be an integer of at least 1"},
           {R"({"v":1,"cmd":"trace","port":"J.r","count":1.5})", "\"count\""},
           {R"({"v":1,"cmd":"trace","port":"J.r","duration":0})", "\"duration\" must be a number of seconds"},
           {R"({"v":1,"cmd":"trace","port":"J.r","duration":"1"})", "\"duration\""},
           {R"({"v":1,"cmd":"stats","port":"J.r"})", "takes no \"port\""}}) {
    EXPECT_FALSE(parse(bad, error)) << bad;
    EXPECT_EQ(error.code, kBadRequest) << bad;
    EXPECT_NE(error.message.find(says), std::string::npos) << bad << ": " << error.message;
  }
  const std::string sample = sample_line(5, 1234, "Joystick.reference", R"({"speed_mps":0.9})");
  ASSERT_EQ(sample.back(), '\n');
  const json j = json::parse(sample);
  EXPECT_EQ(j, json::parse(R"({"v":1,"id":5,"ok":true,"sample":{"t_ns":1234,"port":"Joystick.reference","value":{"speed_mps":0.9}}})"));
}

TEST(AdminRequest, ParsesPropertyAndWiringCommands) {
  ParseError error;
  auto all = parse(R"({"v":1,"cmd":"get","component":"Joystick"})", error);
  ASSERT_TRUE(all) << error.message;
  EXPECT_EQ(all->command, Command::get);
  EXPECT_EQ(all->component, "Joystick");
  EXPECT_EQ(all->property, "");
  auto one = parse(R"({"v":1,"cmd":"get","component":"Joystick","property":"max_speed"})", error);
  ASSERT_TRUE(one) << error.message;
  EXPECT_EQ(one->property, "max_speed");
  // A value may be given as a string, a number or a boolean; it travels as text.
  for (const auto& [json_value, text] : {std::pair{R"("0.8")", "0.8"}, std::pair{"0.8", "0.8"}, std::pair{"3", "3"},
                                         std::pair{"-3", "-3"}, std::pair{"true", "true"}, std::pair{R"("")", ""}}) {
    auto set = parse(std::string(R"({"v":1,"cmd":"set","component":"J","property":"p","value":)") + json_value + "}", error);
    ASSERT_TRUE(set) << json_value << ": " << error.message;
    EXPECT_EQ(set->command, Command::set);
    EXPECT_EQ(set->value, text) << json_value;
  }
  auto connect = parse(R"({"v":1,"cmd":"connect","source":"HW.joystick","target":"Spare.position","policy":"buffer","depth":8})", error);
  ASSERT_TRUE(connect) << error.message;
  EXPECT_EQ(connect->source, "HW.joystick");
  EXPECT_EQ(connect->target, "Spare.position");
  EXPECT_EQ(connect->policy, "buffer");
  EXPECT_EQ(connect->depth, 8);
  auto bare = parse(R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i"})", error);
  ASSERT_TRUE(bare) << error.message;
  EXPECT_EQ(bare->policy, "");
  EXPECT_FALSE(bare->depth);
  // The depth's range is the loader's to check, as for a profile: any integer passes here.
  auto zero = parse(R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i","depth":0})", error);
  ASSERT_TRUE(zero) << error.message;
  EXPECT_EQ(zero->depth, 0);
  auto disconnect = parse(R"({"v":1,"cmd":"disconnect","source":"A.o","target":"B.i"})", error);
  ASSERT_TRUE(disconnect) << error.message;
  EXPECT_EQ(disconnect->command, Command::disconnect);
}

TEST(AdminRequest, RefusesBadPropertyAndWiringRequests) {
  struct Case {
    const char* line;
    const char* says;
  };
  for (const Case& c : {
           Case{R"({"v":1,"cmd":"get"})", "'get' needs \"component\""},
           Case{R"({"v":1,"cmd":"get","component":"J","property":""})", "\"property\" must be a non-empty string"},
           Case{R"({"v":1,"cmd":"get","component":"J","value":"1"})", "'get' takes no \"value\""},
           Case{R"({"v":1,"cmd":"set","component":"J","value":"1"})", "'set' needs \"property\""},
           Case{R"({"v":1,"cmd":"set","component":"J","property":"p"})", "'set' needs \"value\""},
           Case{R"({"v":1,"cmd":"set","component":"J","property":"p","value":null})", "\"value\" must be a string, a number or a boolean"},
           Case{R"({"v":1,"cmd":"set","component":"J","property":"p","value":[1]})", "\"value\" must be a string, a number or a boolean"},
           Case{R"({"v":1,"cmd":"connect","target":"B.i"})", "'connect' needs \"source\": a port as COMPONENT.PORT"},
           Case{R"({"v":1,"cmd":"connect","source":"A","target":"B.i"})", "\"source\" must name a port as COMPONENT.PORT, not 'A'"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":".i"})", "\"target\" must name a port as COMPONENT.PORT"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":"B."})", "\"target\" must name a port as COMPONENT.PORT"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i","depth":"8"})", "\"depth\" must be an integer"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i","depth":1.5})", "\"depth\" must be an integer"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i","depth":18446744073709551615})", "\"depth\" must be an integer"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i","policy":7})", "\"policy\" must be a non-empty string"},
           Case{R"({"v":1,"cmd":"connect","source":"A.o","target":"B.i","component":"A"})", "'connect' takes no \"component\""},
           Case{R"({"v":1,"cmd":"disconnect","source":"A.o","target":"B.i","policy":"data"})", "'disconnect' takes no \"policy\""},
           Case{R"({"v":1,"cmd":"list","source":"A.o"})", "'list' takes no \"source\""},
       }) {
    ParseError error;
    EXPECT_FALSE(parse(c.line, error)) << c.line;
    EXPECT_EQ(error.code, kBadRequest) << c.line;
    EXPECT_NE(error.message.find(c.says), std::string::npos) << c.line << ": " << error.message;
  }
}

TEST(AdminRequest, RequestLinesRoundTripEveryField) {
  Request set;
  set.id = "s";
  set.command = Command::set;
  set.component = "Joystick";
  set.property = "max_speed";
  set.value = "0.8";
  Request connect;
  connect.id = 4;
  connect.command = Command::connect;
  connect.source = "HW.joystick";
  connect.target = "Spare.position";
  connect.policy = "circular";
  connect.depth = 8;
  Request get;
  get.command = Command::get;
  get.component = "HW";
  for (const Request& r : {set, connect, get}) {
    const std::string line = request_line(r);
    ASSERT_EQ(line.back(), '\n');
    ParseError error;
    auto back = parse_request(std::string_view(line).substr(0, line.size() - 1), error);
    ASSERT_TRUE(back) << line << error.message;
    EXPECT_EQ(back->id, r.id);
    EXPECT_EQ(back->command, r.command);
    EXPECT_EQ(back->component, r.component);
    EXPECT_EQ(back->property, r.property);
    EXPECT_EQ(back->value, r.value);
    EXPECT_EQ(back->source, r.source);
    EXPECT_EQ(back->target, r.target);
    EXPECT_EQ(back->policy, r.policy);
    EXPECT_EQ(back->depth, r.depth);
  }
  // Only the fields of the command go out.
  EXPECT_EQ(request_line(get).find("property"), std::string::npos) << request_line(get);
  EXPECT_EQ(request_line(connect).find("component"), std::string::npos) << request_line(connect);
}

TEST(AdminRequest, ParsesAConditionSwitchAndRoundTripsIt) {
  ParseError error;
  auto on = parse(R"({"v":1,"id":3,"cmd":"condition","port":"client.event","active":true,"mode":"single",)"
                  R"("parameters":{"min_x":2.5,"level":15}})",
                  error);
  ASSERT_TRUE(on) << error.message;
  EXPECT_EQ(on->command, Command::condition);
  EXPECT_EQ(on->port, "client.event");
  EXPECT_TRUE(on->active);
  EXPECT_EQ(on->mode, "single");
  ASSERT_EQ(on->parameters.size(), 2u);
  EXPECT_EQ(on->parameters[0], (std::pair<std::string, double>{"level", 15.0}));  // JSON objects are ordered by name
  EXPECT_EQ(on->parameters[1], (std::pair<std::string, double>{"min_x", 2.5}));
  const std::string line = request_line(*on);
  auto back = parse_request(std::string_view(line).substr(0, line.size() - 1), error);
  ASSERT_TRUE(back) << line << error.message;
  EXPECT_EQ(back->port, on->port);
  EXPECT_EQ(back->active, on->active);
  EXPECT_EQ(back->mode, on->mode);
  EXPECT_EQ(back->parameters, on->parameters);
  auto off = parse(R"({"v":1,"cmd":"condition","port":"client.event","active":false})", error);
  ASSERT_TRUE(off) << error.message;
  EXPECT_FALSE(off->active);
  EXPECT_TRUE(off->parameters.empty());
  EXPECT_EQ(request_line(*off).find("mode"), std::string::npos) << request_line(*off);

  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {R"({"v":1,"cmd":"condition","port":"c.e"})", "needs \"active\""},
           {R"({"v":1,"cmd":"condition","active":true})", "needs \"port\""},
           {R"({"v":1,"cmd":"condition","port":"c.e","active":1})", "\"active\" must be true or false"},
           {R"({"v":1,"cmd":"condition","port":"c.e","active":true,"mode":"twice"})", "\"mode\" must be"},
           {R"({"v":1,"cmd":"condition","port":"c.e","active":true,"parameters":[1]})", "an object of finite numbers"},
           {R"({"v":1,"cmd":"condition","port":"c.e","active":true,"parameters":{"a":"1"}})", "('a' is not)"},
           {R"({"v":1,"cmd":"condition","port":"c.e","active":true,"parameters":{"big":1e400}})", "not JSON"},
           {R"({"v":1,"cmd":"trace","port":"c.e","active":true})", "'trace' takes no \"active\""},
       }) {
    EXPECT_FALSE(parse(text, error)) << text;
    EXPECT_EQ(error.code, kBadRequest) << text;
    EXPECT_NE(error.message.find(expected), std::string::npos) << text << ": " << error.message;
  }
}

TEST(AdminRequest, RefusesALineOverTheBound) {
  ParseError error;
  const std::string line = R"({"v":1,"cmd":"hello","pad":")" + std::string(kMaxRequestLine, 'x') + "\"}";
  EXPECT_FALSE(parse(line, error));
  EXPECT_EQ(error.code, kTooLong);
}

TEST(AdminReply, IsOneJsonLineWithVersionAndId) {
  const std::string ok = ok_reply(5, {{"a", 1}});
  ASSERT_EQ(ok.back(), '\n');
  EXPECT_EQ(ok.find('\n'), ok.size() - 1);
  const json j = json::parse(ok);
  EXPECT_EQ(j["v"], kProtocolVersion);
  EXPECT_EQ(j["id"], 5);
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["result"]["a"], 1);
  // Bytes that are not UTF-8 (a component name from a request) do not throw.
  const json e = json::parse(error_reply("x", kUnknownComponent, "no component named '\xff'"));
  EXPECT_EQ(e["ok"], false);
  EXPECT_EQ(e["code"], kUnknownComponent);
  EXPECT_EQ(e["id"], "x");
  ParseError error;
  auto round = parse_request(request_line(9, Command::reset, "HW").substr(0, request_line(9, Command::reset, "HW").size() - 1), error);
  ASSERT_TRUE(round) << error.message;
  EXPECT_EQ(round->command, Command::reset);
  EXPECT_EQ(round->component, "HW");
}

TEST(LineBuffer, SplitsLinesAcrossChunks) {
  LineBuffer in(16);
  std::string line;
  in.append("ab", 2);
  EXPECT_EQ(in.next(line), LineBuffer::Next::need_more);
  in.append("c\r\nde\nf", 7);
  ASSERT_EQ(in.next(line), LineBuffer::Next::line);
  EXPECT_EQ(line, "abc");
  ASSERT_EQ(in.next(line), LineBuffer::Next::line);
  EXPECT_EQ(line, "de");
  EXPECT_EQ(in.next(line), LineBuffer::Next::need_more);
  in.append("\n", 1);
  ASSERT_EQ(in.next(line), LineBuffer::Next::line);
  EXPECT_EQ(line, "f");
  EXPECT_EQ(in.buffered(), 0u);
}

TEST(LineBuffer, ALineOverTheBoundIsTooLongBeforeItsNewlineArrives) {
  LineBuffer in(16);
  std::string line;
  const std::string sixteen(16, 'x');
  in.append(sixteen.data(), sixteen.size());
  EXPECT_EQ(in.next(line), LineBuffer::Next::need_more);  // exactly the bound: may still end
  in.append("y", 1);
  EXPECT_EQ(in.next(line), LineBuffer::Next::too_long);
  LineBuffer complete(4);
  complete.append("12345\n", 6);
  EXPECT_EQ(complete.next(line), LineBuffer::Next::too_long);
}

}  // namespace
}  // namespace polyport::admin
