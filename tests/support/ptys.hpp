// Pseudo-terminals standing in for serial ports where augerd's start-up checks are tested: a
// pty's slave side is a tty (/proc/tty/drivers' pty:slave), as a port must be; /dev/null and
// /dev/zero are not. The masters stay open as long as the object lives.
#pragma once

#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <stdexcept>
#include <string>
#include <vector>

struct Ptys {
  std::vector<int> masters;
  std::vector<std::string> names;  // the slave sides, /dev/pts/N
  explicit Ptys(int n) {
    for (int i = 0; i < n; ++i) {
      const int m = posix_openpt(O_RDWR | O_NOCTTY);
      if (m < 0 || grantpt(m) != 0 || unlockpt(m) != 0 || !ptsname(m)) throw std::runtime_error("no pty");
      masters.push_back(m);
      names.push_back(ptsname(m));
    }
  }
  ~Ptys() {
    for (int m : masters) close(m);
  }
  Ptys(const Ptys&) = delete;
  Ptys& operator=(const Ptys&) = delete;
};
