// Helpers shared by the C++ peer benchmarks (pinocchio_kinematics.cpp,
// coal_collision.cpp): a compiler barrier for timed calls and JSON string
// escaping for their one-object output.
#pragma once

#include <cstdio>
#include <string>

namespace peer
{
  // Like benchmark::DoNotOptimize + ClobberMemory: the value "escapes" and all memory
  // is considered read/written, so no store done by the measured call can be elided.
  template<typename T>
  inline void escape(const T * p)
  {
    asm volatile("" : : "g"(p) : "memory");
  }

  inline std::string json_escape(const std::string & s)
  {
    std::string o;
    for (char c : s)
    {
      if (c == '"' || c == '\\')
      {
        o += '\\';
        o += c;
      }
      else if ((unsigned char)c < 0x20)
      {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", c);
        o += buf;
      }
      else
        o += c;
    }
    return o;
  }
} // namespace peer
