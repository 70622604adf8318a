// Fast DDS's own log messages, routed to polyport's standard error.
//
// Left alone, Fast DDS 2.9 prints its log entries (errors, by default) on standard output,
// in colour, from its logging thread, whenever that thread gets to them, possibly after the
// process has reported the failure they explain. polyport keeps standard output for what a
// command prints (`check --json`, `types`) and logs on standard error, so the first Fast DDS
// participant polyport creates replaces Fast DDS's consumers with one that writes each entry
// as one line on standard error:
//
//   2026-11-21T20:36:20.552 error fastdds XMLPARSER: Error parsing participant profile (parseXMLParticipantProf)
//
// (the timestamp, the level as polyport's logger spells it, Fast DDS's category, message and
// function). Written with one stdio call per line, not through spdlog: Fast DDS's logging
// thread can still deliver entries while the process exits, after polyport's logger is gone.
// The verbosity stays Fast DDS's (errors only unless the application changes it).
#pragma once

namespace polyport::fastdds {

// Installs the consumer; once per process, later calls do nothing.
void route_sdk_log();

// Waits until Fast DDS's logging thread has written every entry queued so far: called before
// polyport reports a failure that Fast DDS explains, so its lines come first.
void flush_sdk_log();

}  // namespace polyport::fastdds
