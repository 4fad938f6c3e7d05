// Where work that may block runs: the server hands its worker pool to the Drive seam so that a
// family's asynchronous command can finish on a thread that may wait (an audit append), never on
// the family's I/O thread (issue 10, P1; docs/decisions/1301-async-move.md).
#pragma once

#include <functional>

namespace drivegw {

class Executor {
 public:
  virtual ~Executor() = default;
  // Runs `task` on one of the executor's threads, later; never inline while the executor runs.
  // Must not block the caller beyond a queue lock (families call it from their I/O thread).
  virtual void Post(std::function<void()> task) = 0;
};

}  // namespace drivegw
