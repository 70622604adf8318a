// The native relay between raw SocketCAN and Fast DDS programs (relay.hpp): the kernel's CAN API
// and the Fast DDS SDK with its generated types, no polyport.
//   relay_can_fastdds PING_MODEL DOMAIN_PING DOMAIN_PONG SIZE   (a CAN domain N is the interface vcanN;
//   SIZE 1024: CAN FD 64-byte frames)
#include "side_can.hpp"
#include "side_fastdds.hpp"

int main(int argc, char** argv) { return bench::relay::relay_main<bench::relay::CanSide, bench::relay::FastddsSide>(argc, argv); }
