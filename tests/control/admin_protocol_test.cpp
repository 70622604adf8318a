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
  for (const char* name : {"activate", "deactivate", "reset"}) {
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
                        Case{R"({"v":1,"id":3,"cmd":"reload"})", kUnknownCommand, "unknown command 'reload'"},
                        Case{R"({"v":1,"id":3,"cmd":"activate"})", kBadRequest, "needs \"component\""},
                        Case{R"({"v":1,"id":3,"cmd":"activate","component":""})", kBadRequest, "needs \"component\""},
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
