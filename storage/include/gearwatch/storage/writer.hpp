#pragma once
// The single writer: one thread owns the only writing connection and commits what the
// processing thread submits, in batched transactions.
//
// Overflow policy: the queue is bounded; submit() waits when it is full (counted in
// queue_waits), so a stalled disk slows processing down instead of dropping results — the
// acquisition ring in front of processing absorbs and counts what cannot wait.
// Errors: a transient SQLite error (database locked, disk full, I/O error) rolls the batch
// back, keeps it in memory, logs once per interval and retries with backoff; nothing submitted
// is dropped while the process lives. A permanent error (corrupt file, schema mismatch) goes to
// the error handler, which the daemon uses to stop. A constraint failure is a bug in what was
// submitted, never a reason to stop: the optional parts of a record (skips, wear assessments,
// alerts) are each written in their own savepoint, so a refused part is logged with its content,
// counted (rows_rejected) and dropped alone while the record and its indicators are stored; a
// refused whole message is logged, counted in lost_at_exit, and the writer goes on.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "gearwatch/storage/messages.hpp"
#include "gearwatch/storage/outbox.hpp"
#include "gearwatch/storage/schema.hpp"

namespace gearwatch::storage {

struct WriterOptions {
  std::string database;
  int busy_timeout_ms = 5000;
  std::size_t queue_capacity = 256;
  std::size_t max_batch = 512;          ///< messages per transaction
  int retry_initial_ms = 200;
  int retry_max_ms = 30000;
  double give_up_after_stop_s = 60.0;   ///< after stop(), retries end after this long
  Vocabulary vocabulary;                ///< domains beyond core's (see open_and_migrate)
  /// Set when MQTT publishing is on: records, alerts, model runs, gap reports and health
  /// snapshots then also write their outbox rows in their own transaction (outbox.hpp).
  std::optional<OutboxIdentity> outbox;
};

struct WriterCounters {
  std::atomic<std::uint64_t> messages_committed{0};
  std::atomic<std::uint64_t> transactions{0};
  std::atomic<std::uint64_t> retries{0};       ///< transient failures retried
  std::atomic<std::uint64_t> queue_waits{0};   ///< submit() calls that had to wait
  std::atomic<std::uint64_t> lost_at_exit{0};  ///< messages not written (refused, or retries given up)
  std::atomic<std::uint64_t> rows_rejected{0}; ///< parts of records refused by a constraint (a bug)
  std::atomic<std::uint64_t> run_id{0};
};

class StorageWriter {
 public:
  using ErrorHandler = std::function<void(const std::string&)>;

  explicit StorageWriter(WriterOptions options, ErrorHandler on_fatal = {});
  ~StorageWriter();
  StorageWriter(const StorageWriter&) = delete;
  StorageWriter& operator=(const StorageWriter&) = delete;

  /// Opens the database on the writer thread and migrates it; throws SqliteError (from the
  /// caller's thread) when that fails, so a daemon with an unusable database never starts.
  void start();
  /// Queues a message; waits while the queue is full. Callable from one or more threads.
  void submit(Message message);
  /// Sends the terminate message and joins: returns when everything submitted is committed
  /// (or the retry deadline after stop has passed; then lost_at_exit says how much).
  void stop();

  const WriterCounters& counters() const noexcept { return counters_; }
  std::size_t queued() const;

 private:
  class Loop;  ///< the writer thread's loop (writer.cpp)

  WriterOptions options_;
  ErrorHandler on_fatal_;
  WriterCounters counters_;
  mutable std::mutex mutex_;
  std::condition_variable not_empty_, not_full_;
  std::deque<Message> queue_;
  bool terminate_ = false;
  std::thread thread_;
};

}  // namespace gearwatch::storage
