// MCAP records (specification version 0): little-endian integers, strings and byte arrays
// prefixed by their uint32 length, maps by their uint32 byte length.
#include "auger/mcap.hpp"

#include <array>
#include <stdexcept>

#include <zstd.h>

namespace auger {

namespace {

constexpr char kMagic[] = "\x89MCAP0\r\n";  // 8 bytes

enum Op : std::uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B, kMetadata = 0x0C,
  kMetadataIndex = 0x0D, kSummaryOffset = 0x0E, kDataEnd = 0x0F,
};

void put(std::string& b, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) b.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void u8(std::string& b, std::uint8_t v) { put(b, v, 1); }
void u16(std::string& b, std::uint16_t v) { put(b, v, 2); }
void u32(std::string& b, std::uint32_t v) { put(b, v, 4); }
void u64(std::string& b, std::uint64_t v) { put(b, v, 8); }
void str(std::string& b, const std::string& s) {
  u32(b, static_cast<std::uint32_t>(s.size()));
  b += s;
}
void string_map(std::string& b, const McapWriter::Metadata& m) {
  std::string e;
  for (const auto& [k, v] : m) {
    str(e, k);
    str(e, v);
  }
  str(b, e);
}
std::string record(std::uint8_t opcode, const std::string& body) {
  std::string r;
  u8(r, opcode);
  u64(r, body.size());
  return r + body;
}

const std::array<std::uint32_t, 256>& crc_table() {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  return table;
}

}  // namespace

std::uint32_t crc32_update(std::uint32_t crc, const void* data, std::size_t n) {
  const auto& t = crc_table();
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) crc = t[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

McapWriter::McapWriter(std::ostream& out, const std::string& profile, const std::string& library,
                       std::size_t chunk_bytes)
    : out_(&out), chunk_bytes_(chunk_bytes) {
  const std::string magic(kMagic, 8);
  out_->write(magic.data(), 8);
  data_crc_ = crc32_update(0, magic.data(), 8);
  offset_ = 8;
  std::string h;
  str(h, profile);
  str(h, library);
  write_record(kHeader, h);
}

McapWriter::~McapWriter() {
  try {
    finish();
  } catch (...) {
  }
}

void McapWriter::write_record(std::uint8_t opcode, const std::string& body) {
  const std::string r = record(opcode, body);
  out_->write(r.data(), static_cast<std::streamsize>(r.size()));
  data_crc_ = crc32_update(data_crc_, r.data(), r.size());
  offset_ += r.size();
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (finished_) throw std::logic_error("McapWriter: add_schema after finish");
  const auto id = static_cast<std::uint16_t>(schemas_.size() + 1);
  std::string b;
  u16(b, id);
  str(b, name);
  str(b, encoding);
  str(b, data);
  write_record(kSchema, b);
  schemas_.push_back(b);
  return id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic,
                                      const std::string& message_encoding, const Metadata& metadata) {
  if (finished_) throw std::logic_error("McapWriter: add_channel after finish");
  if (schema_id > schemas_.size()) throw std::invalid_argument("McapWriter: unknown schema id");
  const auto id = static_cast<std::uint16_t>(channels_.size() + 1);
  std::string b;
  u16(b, id);
  u16(b, schema_id);
  str(b, topic);
  str(b, message_encoding);
  string_map(b, metadata);
  write_record(kChannel, b);
  channels_.push_back(b);
  sequence_.push_back(0);
  channel_counts_[id] = 0;
  return id;
}

void McapWriter::write_message(std::uint16_t channel_id, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
                               const std::string& data) {
  if (finished_) throw std::logic_error("McapWriter: write_message after finish");
  if (channel_id == 0 || channel_id > channels_.size()) throw std::invalid_argument("McapWriter: unknown channel id");
  if (chunk_.empty() || log_time_ns < chunk_start_ns_) chunk_start_ns_ = log_time_ns;
  if (chunk_.empty() || log_time_ns > chunk_end_ns_) chunk_end_ns_ = log_time_ns;
  chunk_index_[channel_id].emplace_back(log_time_ns, chunk_.size());
  std::string b;
  u16(b, channel_id);
  u32(b, sequence_[channel_id - 1]++);
  u64(b, log_time_ns);
  u64(b, publish_time_ns);
  b += data;
  chunk_ += record(kMessage, b);
  if (message_count_ == 0 || log_time_ns < start_ns_) start_ns_ = log_time_ns;
  if (message_count_ == 0 || log_time_ns > end_ns_) end_ns_ = log_time_ns;
  ++message_count_;
  ++channel_counts_[channel_id];
  if (chunk_.size() >= chunk_bytes_) close_chunk();
}

void McapWriter::write_metadata(const std::string& name, const Metadata& metadata) {
  if (finished_) throw std::logic_error("McapWriter: write_metadata after finish");
  close_chunk();  // metadata records sit between chunks
  std::string b;
  str(b, name);
  string_map(b, metadata);
  const std::uint64_t at = offset_;
  write_record(kMetadata, b);
  metadata_index_.emplace_back(at, name);
  metadata_length_.push_back(offset_ - at);
}

void McapWriter::close_chunk() {
  if (chunk_.empty()) return;
  ChunkIndex ci{};
  ci.start_ns = chunk_start_ns_;
  ci.end_ns = chunk_end_ns_;
  ci.offset = offset_;
  ci.size = chunk_.size();
  // zstd at its fastest level: JSON rows shrink about tenfold (augerd's MCAP file was 3.5 times
  // its CSV file), at a few ms of CPU per second of log on the board.
  std::string packed(ZSTD_compressBound(chunk_.size()), '\0');
  const std::size_t n = ZSTD_compress(packed.data(), packed.size(), chunk_.data(), chunk_.size(), 1);
  if (ZSTD_isError(n)) throw std::runtime_error(std::string("McapWriter: zstd: ") + ZSTD_getErrorName(n));
  packed.resize(n);
  ci.compressed_size = n;
  std::string b;
  u64(b, chunk_start_ns_);
  u64(b, chunk_end_ns_);
  u64(b, chunk_.size());
  u32(b, crc32_update(0, chunk_.data(), chunk_.size()));
  str(b, "zstd");
  u64(b, packed.size());
  b += packed;
  write_record(kChunk, b);
  ci.length = offset_ - ci.offset;
  const std::uint64_t index_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    std::string m;
    u16(m, channel);
    u32(m, static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) {
      u64(m, t);
      u64(m, off);
    }
    ci.index_offsets[channel] = offset_;
    write_record(kMessageIndex, m);
  }
  ci.index_length = offset_ - index_start;
  chunk_indexes_.push_back(ci);
  chunk_.clear();
  chunk_index_.clear();
}

void McapWriter::flush() {
  if (finished_) return;
  close_chunk();
  out_->flush();
}

void McapWriter::finish() {
  if (finished_) return;
  close_chunk();
  finished_ = true;
  const std::string t = tail();
  out_->write(t.data(), static_cast<std::streamsize>(t.size()));
  offset_ += t.size();
  out_->flush();
}

std::string McapWriter::tail() const {
  if (!chunk_.empty()) throw std::logic_error("McapWriter: tail with an open chunk (flush first)");
  std::string out;
  std::uint64_t offset = offset_;
  std::string de;
  u32(de, data_crc_);
  out += record(kDataEnd, de);
  offset += out.size();

  // The summary: each group of records, then an offset record per group, then the footer.
  const std::uint64_t summary_start = offset;
  std::uint32_t crc = 0;
  std::vector<std::string> offsets;
  auto emit = [&](const std::string& r) {
    out += r;
    crc = crc32_update(crc, r.data(), r.size());
    offset += r.size();
  };
  auto group = [&](std::uint8_t opcode, const std::vector<std::string>& bodies) {
    if (bodies.empty()) return;
    const std::uint64_t start = offset;
    for (const auto& body : bodies) emit(record(opcode, body));
    std::string so;
    u8(so, opcode);
    u64(so, start);
    u64(so, offset - start);
    offsets.push_back(so);
  };
  group(kSchema, schemas_);
  group(kChannel, channels_);
  std::vector<std::string> cis;
  for (const auto& c : chunk_indexes_) {
    std::string b;
    u64(b, c.start_ns);
    u64(b, c.end_ns);
    u64(b, c.offset);
    u64(b, c.length);
    std::string m;
    for (const auto& [ch, off] : c.index_offsets) {
      u16(m, ch);
      u64(m, off);
    }
    str(b, m);
    u64(b, c.index_length);
    str(b, "zstd");
    u64(b, c.compressed_size);
    u64(b, c.size);
    cis.push_back(b);
  }
  group(kChunkIndex, cis);
  std::vector<std::string> mis;
  for (std::size_t i = 0; i < metadata_index_.size(); ++i) {
    std::string b;
    u64(b, metadata_index_[i].first);
    u64(b, metadata_length_[i]);
    str(b, metadata_index_[i].second);
    mis.push_back(b);
  }
  group(kMetadataIndex, mis);
  std::string st;
  u64(st, message_count_);
  u16(st, static_cast<std::uint16_t>(schemas_.size()));
  u32(st, static_cast<std::uint32_t>(channels_.size()));
  u32(st, 0);  // attachments
  u32(st, static_cast<std::uint32_t>(metadata_index_.size()));
  u32(st, static_cast<std::uint32_t>(chunk_indexes_.size()));
  u64(st, start_ns_);
  u64(st, end_ns_);
  std::string counts;
  for (const auto& [ch, n] : channel_counts_) {
    u16(counts, ch);
    u64(counts, n);
  }
  str(st, counts);
  group(kStatistics, {st});

  const std::uint64_t summary_offset_start = offset;
  for (const auto& so : offsets) emit(record(kSummaryOffset, so));
  // The footer's CRC covers the summary through the footer's summary_offset_start field.
  std::string f;
  u8(f, kFooter);
  u64(f, 8 + 8 + 4);
  u64(f, summary_start);
  u64(f, summary_offset_start);
  crc = crc32_update(crc, f.data(), f.size());
  u32(f, crc);
  out += f;
  out.append(kMagic, 8);
  return out;
}

}  // namespace auger
