// A streaming writer of MCAP files (the container Foxglove and PlotJuggler open; record layout
// of the MCAP specification, version 0): schemas, channels, messages in zstd-compressed chunks
// with message indexes, metadata, and a summary (schemas, channels, chunk and metadata indexes,
// statistics) so readers can seek. CRC-32 over every chunk, the data section and the summary.
// tail() gives the summary of what is written so far, so that a file can be complete after
// every flush (augerd's log: a kill or a full disk leaves a file every reader opens).
// Written here because no MCAP library for C++ is packaged in Debian 12 (docs/design.md: no
// vendored code); `auger export` and augerd use it, and the tests read its files back with the
// independent Python reader (PyPI `mcap`). log_mcap.hpp maps robot-log rows onto channels.
#pragma once

#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace auger {

class McapWriter {
 public:
  using Metadata = std::vector<std::pair<std::string, std::string>>;
  // Writes the magic and the header record. chunk_bytes: a chunk is closed once its records
  // reach this size (and at flush()).
  McapWriter(std::ostream& out, const std::string& profile, const std::string& library,
             std::size_t chunk_bytes = 1u << 20);
  ~McapWriter();  // finish() if not yet done (errors then ignored: call finish() to see them)
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // Ids start at 1 (0 is "no schema").
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const Metadata& metadata = {});
  void write_message(std::uint16_t channel_id, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
                     const std::string& data);
  void write_metadata(const std::string& name, const Metadata& metadata);
  // Closes the open chunk, so everything written so far is in the file (streams flushed too).
  void flush();
  // Closes the data section, writes the summary and the footer. Nothing can be written after.
  void finish();
  // What finish() would write now (after flush()), without writing it: written after the data
  // so far, it makes a complete file; the next data then goes where it began.
  std::string tail() const;
  std::uint64_t message_count() const { return message_count_; }

 private:
  struct ChunkIndex {
    std::uint64_t start_ns, end_ns, offset, length, index_length, size, compressed_size;
    std::map<std::uint16_t, std::uint64_t> index_offsets;
  };
  void write_record(std::uint8_t opcode, const std::string& body);  // to the file, CRC updated
  void close_chunk();

  std::ostream* out_;
  std::size_t chunk_bytes_;
  bool finished_ = false;
  std::uint64_t offset_ = 0;       // bytes written to the file
  std::uint32_t data_crc_ = 0;     // running CRC-32 of the data section (before final xor)
  std::vector<std::string> schemas_, channels_;  // their records, repeated in the summary
  std::vector<std::pair<std::uint64_t, std::string>> metadata_index_;  // offset, record for the index
  std::vector<std::uint64_t> metadata_length_;
  std::vector<ChunkIndex> chunk_indexes_;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::vector<std::uint32_t> sequence_;  // per channel id
  std::uint64_t message_count_ = 0, start_ns_ = 0, end_ns_ = 0;
  // the open chunk
  std::string chunk_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;  // time, offset
};

// CRC-32 (ISO-HDLC, as zlib's crc32) continued from crc (0 to start).
std::uint32_t crc32_update(std::uint32_t crc, const void* data, std::size_t n);

}  // namespace auger
