// The native relay between Fast DDS and LCM programs (relay.hpp): both SDKs, their generated
// types, no polyport.
//   relay_fastdds_lcm PING_MODEL DOMAIN_PING DOMAIN_PONG SIZE
#include "side_fastdds.hpp"
#include "side_lcm.hpp"

int main(int argc, char** argv) { return bench::relay::relay_main<bench::relay::FastddsSide, bench::relay::LcmSide>(argc, argv); }
