// A peer built on the OpenIGTLink reference library (Debian's libopenigtlink-dev), for dentsim's
// device tests and `dentsim bench`'s igtl_round_trip. Not part of dentsim: it plays the far end.
//
//   igtl_peer server PORT COUNT PERIOD_US X0 Y0 Z0 X1 Y1 Z1 [POSITION]
//     Waits for one client, sends COUNT TRANSFORM (or POSITION) poses (device "Stylus") moving from P0 to P1,
//     PERIOD_US apart, waits after each for the SENSOR answer (CRC checked by the library), prints
//     "rt_us fx fy fz tx ty tz" per pose, then closes the connection. The first pose waits for the
//     client's session to start; the stream's clock starts at its answer, so a slow start does not
//     leave the other poses overdue (sent back to back, the stream over before the session ran).
//   igtl_peer echo HOST PORT
//     Connects and answers every TRANSFORM at once with a SENSOR of six zeros (the same round
//     trip through the reference library on both ends), until the server closes.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "igtlClientSocket.h"
#include "igtlMessageHeader.h"
#include "igtlPositionMessage.h"
#include "igtlSensorMessage.h"
#include "igtlServerSocket.h"
#include "igtlTransformMessage.h"

static int fail(const char* what) {
  std::fprintf(stderr, "igtl_peer: %s\n", what);
  return 2;
}

// Reads the next message's header; skips bodies of other types. Returns 1 with `header` on a
// message of type `want`, 0 on a closed socket.
static int next_message(igtl::Socket* socket, igtl::MessageHeader::Pointer& header, const char* want) {
  for (;;) {
    header->InitPack();
    int r = socket->Receive(header->GetPackPointer(), header->GetPackSize());
    if (r != header->GetPackSize()) return 0;
    header->Unpack();
    if (std::strcmp(header->GetDeviceType(), want) == 0) return 1;
    socket->Skip(header->GetBodySizeToRead());
  }
}

static int server(int argc, char** argv) {
  if (argc < 11) return fail("server PORT COUNT PERIOD_US X0 Y0 Z0 X1 Y1 Z1");
  int port = std::atoi(argv[2]);
  long count = std::atol(argv[3]);
  long period_us = std::atol(argv[4]);
  double p0[3], p1[3];
  for (int i = 0; i < 3; ++i) {
    p0[i] = std::atof(argv[5 + i]);
    p1[i] = std::atof(argv[8 + i]);
  }
  igtl::ServerSocket::Pointer server = igtl::ServerSocket::New();
  if (server->CreateServer(port) < 0) return fail("cannot listen");
  std::printf("listening\n");
  std::fflush(stdout);
  igtl::ClientSocket::Pointer socket;
  for (int i = 0; i < 600 && !socket.IsNotNull(); ++i) socket = server->WaitForConnection(100);
  if (!socket.IsNotNull()) return fail("no client");
  bool as_position = argc > 11 && std::strcmp(argv[11], "POSITION") == 0;
  igtl::TransformMessage::Pointer pose = igtl::TransformMessage::New();
  pose->SetDeviceName("Stylus");
  igtl::PositionMessage::Pointer position = igtl::PositionMessage::New();
  position->SetDeviceName("Stylus");
  position->SetPackType(igtl::PositionMessage::ALL);
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  igtl::SensorMessage::Pointer sensor = igtl::SensorMessage::New();
  std::vector<std::string> lines;
  lines.reserve(count);
  auto next = std::chrono::steady_clock::now();
  for (long i = 0; i < count; ++i) {
    double s = count > 1 ? double(i) / double(count - 1) : 1.0;
    igtl::Matrix4x4 m;
    igtl::IdentityMatrix(m);
    for (int k = 0; k < 3; ++k) m[k][3] = float(p0[k] + s * (p1[k] - p0[k]));
    pose->SetMatrix(m);
    pose->Pack();
    position->SetPosition(m[0][3], m[1][3], m[2][3]);
    position->SetQuaternion(0.0f, 0.0f, 0.0f, 1.0f);
    position->Pack();
    std::this_thread::sleep_until(next);
    next += std::chrono::microseconds(period_us);
    auto sent = std::chrono::steady_clock::now();
    if (as_position)
      socket->Send(position->GetPackPointer(), position->GetPackSize());
    else
      socket->Send(pose->GetPackPointer(), pose->GetPackSize());
    if (!next_message(socket, header, "SENSOR")) return fail("client closed");
    auto got = std::chrono::steady_clock::now();
    if (i == 0) next = got + std::chrono::microseconds(period_us);
    sensor->SetMessageHeader(header);
    sensor->AllocatePack();
    socket->Receive(sensor->GetPackBodyPointer(), sensor->GetPackBodySize());
    if (!(sensor->Unpack(1) & igtl::MessageHeader::UNPACK_BODY)) return fail("SENSOR body did not unpack (CRC or size)");
    if (sensor->GetLength() != 6) return fail("SENSOR does not have six values");
    double rt = std::chrono::duration<double, std::micro>(got - sent).count();
    char line[256];
    int n = std::snprintf(line, sizeof line, "%.3f", rt);
    for (unsigned k = 0; k < 6; ++k) n += std::snprintf(line + n, sizeof line - n, " %.17g", sensor->GetValue(k));
    lines.push_back(line);
  }
  socket->CloseSocket();
  // Printed after the run: a reader that drains stdout only at the end must not stall the peer.
  for (const std::string& l : lines) std::printf("%s\n", l.c_str());
  std::fflush(stdout);
  return 0;
}

static int echo(int argc, char** argv) {
  if (argc < 4) return fail("echo HOST PORT");
  igtl::ClientSocket::Pointer socket = igtl::ClientSocket::New();
  int r = -1;
  for (int i = 0; i < 100 && r != 0; ++i) {
    r = socket->ConnectToServer(argv[2], std::atoi(argv[3]));
    if (r != 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (r != 0) return fail("cannot connect");
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  igtl::TransformMessage::Pointer pose = igtl::TransformMessage::New();
  igtl::SensorMessage::Pointer force = igtl::SensorMessage::New();
  force->SetDeviceName("Force");
  force->SetLength(6);
  while (next_message(socket, header, "TRANSFORM")) {
    pose->SetMessageHeader(header);
    pose->AllocatePack();
    socket->Receive(pose->GetPackBodyPointer(), pose->GetPackBodySize());
    pose->Unpack(1);
    force->Pack();
    socket->Send(force->GetPackPointer(), force->GetPackSize());
  }
  return 0;
}

int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "server") == 0) return server(argc, argv);
  if (argc > 1 && std::strcmp(argv[1], "echo") == 0) return echo(argc, argv);
  return fail("usage: igtl_peer server ... | igtl_peer echo HOST PORT");
}
