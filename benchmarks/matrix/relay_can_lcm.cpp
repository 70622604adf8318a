// The native relay between raw SocketCAN and LCM programs (relay.hpp): the kernel's CAN API
// and the LCM SDK with its generated types, no polyport.
//   relay_can_lcm PING_MODEL DOMAIN_PING DOMAIN_PONG SIZE   (a CAN domain N is the interface vcanN;
//   SIZE 1024: CAN FD 64-byte frames)
#include "side_can.hpp"
#include "side_lcm.hpp"

int main(int argc, char** argv) { return bench::relay::relay_main<bench::relay::CanSide, bench::relay::LcmSide>(argc, argv); }
