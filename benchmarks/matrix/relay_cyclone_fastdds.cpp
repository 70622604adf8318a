// The native relay between Cyclone DDS and Fast DDS programs (relay.hpp): both SDKs, their generated
// types, no polyport.
//   relay_cyclone_fastdds PING_MODEL DOMAIN_PING DOMAIN_PONG SIZE
#include "side_cyclone.hpp"
#include "side_fastdds.hpp"

int main(int argc, char** argv) { return bench::relay::relay_main<bench::relay::CycloneSide, bench::relay::FastddsSide>(argc, argv); }
