// fw_bench: the motor-module firmware measured in the simulator (docs/benchmarks.md).
//
//   fw_bench [--elf PATH] [--lines] [isr] [rate] [load] [speed]
//
// With no section named it runs all of them and prints markdown tables:
//   isr    cycles of every interrupt handler (vector to reti) and of the control step, and
//          where the busy cycles go (per symbol of the ELF), motor still and at top speed;
//          --lines adds the hottest instructions with their source lines (avr-addr2line)
//   rate   highest encoder edge rate with no lost count, regular and jittered spacing
//          (env RATE_SEED=n: another jitter sequence)
//   load   CPU load (share of cycles not asleep): motor still, top speed, 3x top speed
//   speed  four modules in batch mode as a multiple of real time, 1 and 2 threads
//
// Every scenario runs the real firmware image with a host that sends a setpoint every 10 ms
// and reads the telemetry the module sends every 10 ms; the INA219 is read every 10 ms.
// Cycle counts are simulated cycles (deterministic); wall-clock figures are not.
#include <gelf.h>
#include <libelf.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "protocol.h"
#include "sim_avr.h"
#include "fil_rig.hpp"
#include "encoder_rate.h"
#include "simmod.h"

namespace {

constexpr double kCpuHz = 16e6;
// docs/simulator.md and docs/model-notes.md: 23 rpm at 12 V, 369:1 (estimate), 48 X4 counts.
constexpr double kNoLoadRpmAt12V = 23.0;
constexpr double kGearRatio = 369.0;
constexpr double kCountsPerMotorRev = 48.0;
// The firmware caps the duty at 12 V / battery: the motor never sees more than 12 V.
constexpr double kTopEdgesPerSCapped = kNoLoadRpmAt12V * kGearRatio * kCountsPerMotorRev / 60.0;
// What an uncapped drive would reach on a full 21 V pack (the reference rate).
constexpr double kTopEdgesPerS21V = kTopEdgesPerSCapped * 21.0 / 12.0;
constexpr uint32_t kVectorTableEnd = 26 * 4;  // ATmega328P: 26 vectors of 4 bytes
constexpr uint16_t kOpReti = 0x9518;
constexpr uint16_t kOpRet = 0x9508;

std::string g_elf = AUGER_FIRMWARE_ELF;

// ---- ELF symbols: which function a PC belongs to ----

struct Symbol {
    uint32_t addr, size;
    std::string name;
};

class SymbolMap {
public:
    explicit SymbolMap(const std::string& path)
    {
        if (elf_version(EV_CURRENT) == EV_NONE) throw std::runtime_error("libelf");
        int fd = open(path.c_str(), O_RDONLY);
        if (fd < 0) throw std::runtime_error("cannot open " + path);
        Elf* elf = elf_begin(fd, ELF_C_READ, nullptr);
        Elf_Scn* scn = nullptr;
        while (elf && (scn = elf_nextscn(elf, scn)) != nullptr) {
            GElf_Shdr sh;
            if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB) continue;
            Elf_Data* data = elf_getdata(scn, nullptr);
            size_t n = sh.sh_entsize ? sh.sh_size / sh.sh_entsize : 0;
            for (size_t i = 0; data && i < n; i++) {
                GElf_Sym s;
                if (!gelf_getsym(data, int(i), &s)) continue;
                const char* name = elf_strptr(elf, sh.sh_link, s.st_name);
                int type = GELF_ST_TYPE(s.st_info), bind = GELF_ST_BIND(s.st_info);
                // Functions, and global labels of the assembly files (the ISRs); not the
                // local labels inside them, nor data.
                bool code = type == STT_FUNC || (type == STT_NOTYPE && bind == STB_GLOBAL);
                if (!name || !name[0] || name[0] == '.' || !code || s.st_shndx == SHN_ABS ||
                    s.st_shndx == SHN_UNDEF || s.st_value >= 0x800000)
                    continue;
                syms_.push_back({uint32_t(s.st_value), uint32_t(s.st_size), name});
            }
        }
        if (elf) elf_end(elf);
        close(fd);
        std::sort(syms_.begin(), syms_.end(),
                  [](const Symbol& a, const Symbol& b) { return a.addr < b.addr; });
    }
    const Symbol* at(uint32_t pc) const
    {
        auto it = std::upper_bound(syms_.begin(), syms_.end(), pc,
                                   [](uint32_t v, const Symbol& s) { return v < s.addr; });
        return it == syms_.begin() ? nullptr : &*(it - 1);
    }
    // By name; LTO may have renamed a static function to name.lto_priv.N.
    const Symbol* find(const std::string& name) const
    {
        for (const auto& s : syms_)
            if (s.name == name || s.name.rfind(name + ".", 0) == 0) return &s;
        return nullptr;
    }

private:
    std::vector<Symbol> syms_;
};

std::string vector_name(int v)
{
    switch (v) {
    case 5: return "PCINT2 (encoder)";
    case 6: return "WDT";
    case 7: return "TIMER2_COMPA (1 kHz tick)";
    case 18: return "USART_RX";
    case 19: return "USART_UDRE (TX)";
    case 24: return "TWI (INA219)";
    default: return "vector " + std::to_string(v);
    }
}

// ---- the host: the firmware-in-the-loop rig (sim/rig/fil_rig.hpp) sends setpoints every
// 10 ms and parses the telemetry ----

auger::fil::Rig make_rig(int count, int threads, double battery_v)
{
    auger::fil::RigOptions opt;
    opt.count = count;
    opt.threads = threads;
    opt.battery_v = battery_v;
    opt.elf_path = g_elf;
    return auger::fil::Rig(opt);
}

struct Stats {
    uint64_t n = 0, sum = 0, min = UINT64_MAX, max = 0;
    void add(uint64_t v)
    {
        n++;
        sum += v;
        min = std::min(min, v);
        max = std::max(max, v);
    }
    double mean() const { return n ? double(sum) / double(n) : 0.0; }
};

// ---- profiler: a step hook that follows interrupts and the control step ----

class Profiler {
public:
    Profiler(simmod_t* sim, const SymbolMap& syms) : syms_(syms)
    {
        avr_ = static_cast<avr_t*>(simmod_avr(sim, 0));
        busy_by_pc_.assign(size_t(avr_->flashend) + 1, 0);
        busy_cs_by_pc_.assign(size_t(avr_->flashend) + 1, 0);
        const Symbol* cs = syms.find("control_step");
        if (!cs) throw std::runtime_error("no control_step symbol in the ELF");
        cs_addr_ = cs->addr;
        simmod_set_step_hook(sim, 0, &Profiler::hook, this);
    }
    void set_collecting(bool on) { collecting_ = on; }
    void clear()
    {
        std::fill(busy_by_pc_.begin(), busy_by_pc_.end(), 0);
        std::fill(busy_cs_by_pc_.begin(), busy_cs_by_pc_.end(), 0);
        for (auto& s : isr_) s = Stats{};
        cs_incl_ = cs_excl_ = Stats{};
        busy_ = sleep_ = total_ = wakeups_ = interrupts_ = 0;
    }

    const Stats& isr(int v) const { return isr_[v]; }
    const Stats& control_incl() const { return cs_incl_; }
    const Stats& control_excl() const { return cs_excl_; }
    uint64_t busy() const { return busy_; }
    uint64_t total() const { return total_; }
    uint64_t wakeups() const { return wakeups_; }
    uint64_t interrupts() const { return interrupts_; }
    // The chip's cycles: simavr adds none for the interrupt response (4 cycles, 4 more when
    // the interrupt wakes the CPU from idle sleep: ATmega328P datasheet, 6.7 and 10.1).
    uint64_t chip_busy() const { return busy_ + 4 * interrupts_ + 4 * wakeups_; }
    const std::vector<uint64_t>& busy_by_pc() const { return busy_by_pc_; }
    // Only the cycles spent in the control step and its callees (interrupts excluded).
    const std::vector<uint64_t>& control_busy_by_pc() const { return busy_cs_by_pc_; }

private:
    uint16_t opcode(uint32_t pc) const { return uint16_t(avr_->flash[pc] | (avr_->flash[pc + 1] << 8)); }

    static void hook(void* ctx, int, const simmod_step_info_t* in)
    {
        static_cast<Profiler*>(ctx)->step(*in);
    }

    void step(const simmod_step_info_t& in)
    {
        uint64_t delta = in.cycle_after - in.cycle_before;
        uint64_t busy = delta - in.sleep_cycles;
        if (collecting_) {
            total_ += delta;
            busy_ += busy;
            sleep_ += in.sleep_cycles;
        }
        if (busy) {  // an instruction ran at pc_before
            if (collecting_) busy_by_pc_[in.pc_before] += busy;
            if (in_cs_ && stack_.empty()) {
                cs_excl_acc_ += busy;
                if (collecting_) busy_cs_by_pc_[in.pc_before] += busy;
            }
            uint16_t op = opcode(in.pc_before);
            if (op == kOpReti && !stack_.empty()) {
                Frame f = stack_.back();
                stack_.pop_back();
                if (collecting_) isr_[f.vector].add(in.cycle_after - f.start);
            } else if (op == kOpRet && in_cs_ && stack_.empty() &&
                       (in.sp_after == uint16_t(cs_sp_ + 2) ||
                        // an interrupt taken right after the ret pushed its return address
                        (in.pc_after < kVectorTableEnd && in.sp_after == cs_sp_))) {
                in_cs_ = false;
                if (collecting_) {
                    cs_incl_.add(in.cycle_after - cs_start_);
                    cs_excl_.add(cs_excl_acc_);
                }
            }
        }
        if (in.pc_after < kVectorTableEnd && in.pc_after != 0 && in.pc_before >= kVectorTableEnd) {
            stack_.push_back({int(in.pc_after / 4), in.cycle_after});
            if (collecting_) {
                interrupts_++;
                if (busy == 0) wakeups_++;  // no instruction ran: the CPU was asleep
            }
        }
        if (in.pc_after == cs_addr_ && !in_cs_ && stack_.empty()) {
            in_cs_ = true;
            cs_sp_ = in.sp_after;
            cs_start_ = in.cycle_after;
            cs_excl_acc_ = 0;
        }
    }

    struct Frame {
        int vector;
        uint64_t start;
    };
    const SymbolMap& syms_;
    avr_t* avr_ = nullptr;
    bool collecting_ = false;
    std::vector<uint64_t> busy_by_pc_, busy_cs_by_pc_;
    std::vector<Frame> stack_;
    Stats isr_[26];
    uint32_t cs_addr_ = 0;
    bool in_cs_ = false;
    uint16_t cs_sp_ = 0;
    uint64_t cs_start_ = 0, cs_excl_acc_ = 0;
    Stats cs_incl_, cs_excl_;
    uint64_t busy_ = 0, sleep_ = 0, total_ = 0, wakeups_ = 0, interrupts_ = 0;
};

double cpu_load(simmod_t* sim, uint64_t c0, uint64_t s0)
{
    double dc = double(simmod_cycles(sim, 0) - c0), ds = double(simmod_sleep_cycles(sim, 0) - s0);
    return dc > 0 ? 1.0 - ds / dc : 0.0;
}

// Busy cycles per source line (needs an ELF with debug info: the same code built with -g),
// divided by `per` (seconds or steps); lines at or above `min` only.
void print_lines(const char* title, const std::vector<uint64_t>& pcs, const SymbolMap& syms, double per,
                 double min)
{
    std::string cmd = "avr-addr2line -s -e '" + g_elf + "'";
    std::vector<uint32_t> addrs;
    for (uint32_t pc = 0; pc < pcs.size(); ++pc)
        if (pcs[pc]) {
            addrs.push_back(pc);
            char a[16];
            std::snprintf(a, sizeof a, " 0x%x", pc);
            cmd += a;
        }
    std::map<std::string, uint64_t> by_line;
    if (FILE* f = popen(cmd.c_str(), "r")) {
        char buf[256];
        for (size_t i = 0; i < addrs.size() && std::fgets(buf, sizeof buf, f); ++i) {
            buf[std::strcspn(buf, "\n")] = 0;
            const Symbol* sym = syms.at(addrs[i]);
            by_line[std::string(buf) + " (" + (sym ? sym->name : "?") + ")"] += pcs[addrs[i]];
        }
        pclose(f);
    }
    std::vector<std::pair<uint64_t, std::string>> hot;
    for (auto& [n, c] : by_line) hot.push_back({c, n});
    std::sort(hot.rbegin(), hot.rend());
    std::printf("\n%s:\n\n| line | cycles |\n|---|---|\n", title);
    for (auto& [c, n] : hot)
        if (double(c) / per >= min) std::printf("| %s | %.0f |\n", n.c_str(), double(c) / per);
}

void print_profile(const char* title, const Profiler& p, const SymbolMap& syms, bool lines)
{
    std::map<std::string, uint64_t> by_sym;
    const auto& pcs = p.busy_by_pc();
    for (uint32_t pc = 0; pc < pcs.size(); ++pc) {
        if (!pcs[pc]) continue;
        std::string name;
        if (pc < kVectorTableEnd) {
            name = "vector table jump";
        } else {
            const Symbol* s = syms.at(pc);
            name = s ? s->name : "?";
        }
        by_sym[name] += pcs[pc];
    }
    std::vector<std::pair<uint64_t, std::string>> rows;
    for (auto& [n, c] : by_sym) rows.push_back({c, n});
    std::sort(rows.rbegin(), rows.rend());
    double seconds = double(p.total()) / kCpuHz;
    std::printf("\n%s: %.2f %% busy (%.2f %% on the chip with the interrupt response), %.0f "
                "interrupts/s of which %.0f wake the CPU. Busy cycles per second by symbol "
                "(functions inlined into main count as main):\n\n",
                title, 100.0 * double(p.busy()) / double(p.total()),
                100.0 * double(p.chip_busy()) / double(p.total()), double(p.interrupts()) / seconds,
                double(p.wakeups()) / seconds);
    std::printf("| symbol | cycles/s | share of all cycles |\n|---|---|---|\n");
    for (size_t i = 0; i < rows.size() && i < 16; ++i)
        std::printf("| `%s` | %.0f | %.2f %% |\n", rows[i].second.c_str(), double(rows[i].first) / seconds,
                    100.0 * double(rows[i].first) / double(p.total()));
    {
        std::map<std::string, uint64_t> cs_sym;
        uint64_t cs_total = 0;
        const auto& cpcs = p.control_busy_by_pc();
        for (uint32_t pc = 0; pc < cpcs.size(); ++pc)
            if (cpcs[pc]) {
                const Symbol* s = syms.at(pc);
                cs_sym[s ? s->name : "?"] += cpcs[pc];
                cs_total += cpcs[pc];
            }
        std::vector<std::pair<uint64_t, std::string>> r;
        for (auto& [n, c] : cs_sym) r.push_back({c, n});
        std::sort(r.rbegin(), r.rend());
        uint64_t steps = p.control_excl().n ? p.control_excl().n : 1;
        std::printf("\nInside the control step (own cycles per step, by symbol; %.0f in all):\n\n"
                    "| symbol | cycles per step |\n|---|---|\n", double(cs_total) / double(steps));
        for (size_t i = 0; i < r.size() && i < 12; ++i)
            std::printf("| `%s` | %.0f |\n", r[i].second.c_str(), double(r[i].first) / double(steps));
    }
    if (!lines) return;
    // Source lines shown: at least LMIN cycles/s (default 2000), in the control step LMIN/100 a step.
    const char* lmin_env = std::getenv("LMIN");
    const double lmin = lmin_env ? std::atof(lmin_env) : 2000.0;
    print_lines("Source lines of 2000 cycles/s or more (env LMIN: another threshold)", pcs, syms, seconds, lmin);
    uint64_t steps = p.control_excl().n ? p.control_excl().n : 1;
    print_lines("Control step: source lines of 20 cycles per step or more", p.control_busy_by_pc(), syms,
                double(steps), lmin / 100);
}

// ---- sections ----

void section_isr(bool lines)
{
    SymbolMap syms(g_elf);
    std::printf("\n## Interrupt handlers and the control step (simulated cycles)\n\n"
                "One module, battery 21 V, setpoints and telemetry every 10 ms. Each case runs "
                "1 s of simulated time after 0.5 s of settling.\n");
    struct Case {
        const char* name;
        double omega_rpm;
        double forced_edges_per_s;
    };
    const Case cases[] = {
        {"motor still (enabled, 0 rpm)", 0.0, 0},
        {"top speed (30 rpm commanded: duty capped at 12 V, ~23 rpm)", 30.0, 0},
        {"encoder forced at 3x the 21 V top rate, jittered +-50 %", 10.0, 3 * kTopEdgesPerS21V},
    };
    std::vector<std::pair<std::string, Stats>> isr_rows;
    Stats cs_incl, cs_excl;
    for (const Case& c : cases) {
        auger::fil::Rig b = make_rig(1, 1, 21.0);
        Profiler prof(b.sim(), syms);
        b.command(0, c.omega_rpm, PROTO_SP_ENABLE);
        b.run_for(0.5);
        if (c.forced_edges_per_s > 0) encoder_rate_force(b.sim(), 0, c.forced_edges_per_s, 0.5, 12345);
        prof.set_collecting(true);
        b.run_for(1.0);
        prof.set_collecting(false);
        for (int v = 1; v < 26; ++v) {
            const Stats& s = prof.isr(v);
            if (!s.n) continue;
            auto it = std::find_if(isr_rows.begin(), isr_rows.end(),
                                   [&](auto& r) { return r.first == vector_name(v); });
            if (it == isr_rows.end()) {
                isr_rows.push_back({vector_name(v), s});
            } else {
                it->second.n += s.n;
                it->second.sum += s.sum;
                it->second.min = std::min(it->second.min, s.min);
                it->second.max = std::max(it->second.max, s.max);
            }
        }
        const Stats& ci = prof.control_incl();
        const Stats& ce = prof.control_excl();
        for (const Stats* src : {&ci}) {
            cs_incl.n += src->n;
            cs_incl.sum += src->sum;
            cs_incl.min = std::min(cs_incl.min, src->min);
            cs_incl.max = std::max(cs_incl.max, src->max);
        }
        cs_excl.n += ce.n;
        cs_excl.sum += ce.sum;
        cs_excl.min = std::min(cs_excl.min, ce.min);
        cs_excl.max = std::max(cs_excl.max, ce.max);
        print_profile(c.name, prof, syms, lines);
    }
    std::printf("\nAll three cases together. ISR: from the first instruction of the vector (its "
                "jmp or rjmp) to reti inclusive, as simavr counts; the chip adds 4 cycles of interrupt "
                "response (8 when it wakes from idle sleep), which simavr 1.6 does not model. "
                "Handlers that re-enable interrupts (UART) include any encoder ISR nested in them.\n\n");
    std::printf("| handler | calls | min | mean | max |\n|---|---|---|---|---|\n");
    for (auto& [name, s] : isr_rows)
        std::printf("| %s | %" PRIu64 " | %" PRIu64 " | %.1f | %" PRIu64 " |\n", name.c_str(), s.n, s.min,
                    s.mean(), s.max);
    std::printf("| control step, own cycles (interrupts excluded) | %" PRIu64 " | %" PRIu64
                " | %.0f | %" PRIu64 " |\n",
                cs_excl.n, cs_excl.min, cs_excl.mean(), cs_excl.max);
    std::printf("| control step, call to return (interrupts included) | %" PRIu64 " | %" PRIu64
                " | %.0f | %" PRIu64 " |\n",
                cs_incl.n, cs_incl.min, cs_incl.mean(), cs_incl.max);
}

struct RateResult {
    int64_t lost;
    uint16_t illegal;
    double edges;
};

RateResult try_rate(double edges_per_s, double jitter, double seconds)
{
    auger::fil::Rig b = make_rig(1, 1, 21.0);
    b.command(0, 10.0, PROTO_SP_ENABLE);
    b.run_for(0.3);
    int64_t start = simmod_encoder_count(b.sim(), 0);
    // env RATE_SEED (an integer, default 0): another jitter sequence for the same rates
    const char* seed_env = std::getenv("RATE_SEED");
    uint64_t seed = 0x5eed + uint64_t(edges_per_s) + (seed_env ? std::strtoull(seed_env, nullptr, 10) << 32 : 0);
    encoder_rate_force(b.sim(), 0, edges_per_s, jitter, seed);
    b.run_for(seconds);
    // Hold the pins (a rate of one edge in 30 years), let a telemetry frame report the count.
    encoder_rate_force(b.sim(), 0, 1e-9, 0, 1);
    b.run_for(0.03);
    int64_t truth = simmod_encoder_count(b.sim(), 0);
    const proto_telemetry_t& tm = b.last(0).tm;  // throws without telemetry
    // position_counts counts from the boot count, which was 0 (shaft at angle 0).
    int64_t lost = std::llabs(truth - int64_t(tm.position_counts));
    return {lost + tm.encoder_errors, tm.encoder_errors, double(truth - start)};
}

void section_rate()
{
    std::printf("\n## Highest encoder edge rate with no lost count\n\n"
                "One module, battery 21 V, the host commanding 10 rpm with ENABLE every 10 ms "
                "(the PID saturates against the forced speed: the control step runs its full "
                "path), INA219 read every 10 ms, telemetry every 10 ms. The encoder is forced "
                "(`encoder_rate_force`) for 0.5 s per rate; lost = |true count - "
                "telemetry position_counts| + encoder_errors after the run. Rates rise in steps "
                "of 10 000 edges/s until the first loss. Motor top rate: %.0f edges/s with the "
                "firmware's 12 V duty cap, %.0f edges/s uncapped at 21 V (23 rpm x 21/12 x 369 "
                "x 48 / 60); 3x that = %.0f edges/s.\n\n",
                kTopEdgesPerSCapped, kTopEdgesPerS21V, 3 * kTopEdgesPerS21V);
    std::printf("| spacing | highest rate, no loss | edges in that run | first rate with loss | "
                "lost there (of which illegal) | margin over the 21 V top rate |\n|---|---|---|---|---|---|\n");
    struct Mode {
        const char* name;
        double jitter;
    };
    for (Mode mode : {Mode{"regular", 0.0}, Mode{"jittered, uniform +-50 % of the mean interval", 0.5}}) {
        double best = 0, best_edges = 0, fail = 0;
        RateResult fail_r{0, 0, 0};
        for (double r = 100000; r <= 400000; r += 10000) {
            RateResult res = try_rate(r, mode.jitter, 0.5);
            if (res.lost) {
                fail = r;
                fail_r = res;
                break;
            }
            best = r;
            best_edges = res.edges;
        }
        char fail_s[64] = "none up to 400000", lost_s[64] = "-";
        if (fail > 0) {
            std::snprintf(fail_s, sizeof fail_s, "%.0f", fail);
            std::snprintf(lost_s, sizeof lost_s, "%" PRId64 " (%u)", fail_r.lost, unsigned(fail_r.illegal));
        }
        std::printf("| %s | %.0f | %.0f | %s | %s | %.1fx |\n", mode.name, best, best_edges, fail_s, lost_s,
                    best / kTopEdgesPerS21V);
        std::fflush(stdout);
    }
}

void section_load()
{
    std::printf("\n## CPU load (cycles not asleep / all cycles)\n\n"
                "One module, battery 21 V, setpoints and telemetry every 10 ms, INA219 every "
                "10 ms; 1 s measured after 0.5 s of settling. Sleep cycles counted by the "
                "simulator (`simmod_sleep_cycles`).\n\n"
                "| case | encoder edges/s | CPU load |\n|---|---|---|\n");
    struct Case {
        const char* name;
        double omega_rpm;
        uint8_t flags;
        double forced;
        int telemetry_ms;  // the module's setting (CONFIG); the host still reads every frame
    };
    const Case cases[] = {
        {"motor disabled, still", 0.0, 0, 0, 10},
        {"enabled, 0 rpm, still", 0.0, PROTO_SP_ENABLE, 0, 10},
        {"top speed: 30 rpm commanded, duty capped at 12 V", 30.0, PROTO_SP_ENABLE, 0, 10},
        {"encoder forced at the uncapped 21 V top rate", 10.0, PROTO_SP_ENABLE, kTopEdgesPerS21V, 10},
        {"encoder forced at 3x the 21 V top rate", 10.0, PROTO_SP_ENABLE, 3 * kTopEdgesPerS21V, 10},
        {"top speed, telemetry every 20 ms", 30.0, PROTO_SP_ENABLE, 0, 20},
        {"top speed, telemetry every 100 ms", 30.0, PROTO_SP_ENABLE, 0, 100},
    };
    for (const Case& c : cases) {
        auger::fil::Rig b = make_rig(1, 1, 21.0);
        if (c.telemetry_ms != 10) {
            b.run_for(0.05);
            try {
                b.reconfigure(0, [&](proto_config_t& cfg) { cfg.telemetry_period_ms = uint8_t(c.telemetry_ms); });
            } catch (const std::exception&) {  // an image of protocol 1 (--elf) has no such setting
                std::printf("| %s | - | (not in this image) |\n", c.name);
                continue;
            }
        }
        b.command(0, c.omega_rpm, c.flags);
        b.run_for(0.5);
        if (c.forced > 0) encoder_rate_force(b.sim(), 0, c.forced, 0.0, 7);
        uint64_t c0 = simmod_cycles(b.sim(), 0), s0 = simmod_sleep_cycles(b.sim(), 0);
        int64_t e0 = simmod_encoder_count(b.sim(), 0);
        double t0 = simmod_time_s(b.sim());
        b.run_for(1.0);
        double rate = double(std::llabs(simmod_encoder_count(b.sim(), 0) - e0)) / (simmod_time_s(b.sim()) - t0);
        std::printf("| %s | %.0f | %.2f %% |\n", c.name, rate, 100.0 * cpu_load(b.sim(), c0, s0));
        std::fflush(stdout);
    }
}

void section_speed()
{
    std::printf("\n## Four modules in batch mode\n\n"
                "Four modules, pack model, each commanded 20 rpm with ENABLE every 10 ms "
                "(motors running, telemetry every 10 ms); 3 s of simulated time timed after "
                "0.5 s. Wall-clock: noisy on a shared machine.\n\n"
                "| threads | simulated s | wall s | x real time |\n|---|---|---|---|\n");
    for (int threads : {1, 2}) {
        const int count = 4;
        auger::fil::Rig b = make_rig(count, threads, 0.0);
        for (int m = 0; m < count; ++m) b.command(m, 20.0, PROTO_SP_ENABLE);
        b.run_for(0.5);
        auto w0 = std::chrono::steady_clock::now();
        b.run_for(3.0);
        double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
        for (int i = 0; i < count; ++i)
            if (simmod_state(b.sim(), i) != 0 || b.telemetry(i).size() < 300)
                throw std::runtime_error("module " + std::to_string(i) + " not running");
        std::printf("| %d | 3.0 | %.2f | %.1fx |\n", threads, wall, 3.0 / wall);
        std::fflush(stdout);
    }
}

}  // namespace

int main(int argc, char** argv)
{
    const auger::CommandLine cli{
        "fw_bench", "[OPTIONS] [isr] [rate] [load] [speed]",
        "The firmware's cycle-exact figures from the simulator (docs/benchmarks.md): interrupt and\n"
        "control-step cycles (isr), encoder edge-rate limits (rate), CPU load (load), four modules in\n"
        "batch as a multiple of real time (speed); all four without a section named.\n",
        {{"--elf", "PATH", "another firmware image (default: the one built)"},
         {"--lines", "", "isr: cycles per source line too (an image built with -g)"}},
        "Environment: LMIN (cycles/s) sets the --lines tables' threshold, RATE_SEED another jitter\n"
        "sequence for rate.\n"};
    auger::Args args;
    if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
    if (args.has("--elf")) g_elf = args.get("--elf");
    const bool lines = args.has("--lines");
    std::vector<std::string> sections;
    for (const std::string& a : args.positional) {
        if (a != "isr" && a != "rate" && a != "load" && a != "speed") {
            std::fprintf(stderr, "fw_bench: unknown section '%s'\n", a.c_str());
            cli.print_usage(stderr);
            return 2;
        }
        sections.push_back(a);
    }
    if (sections.empty()) sections = {"isr", "load", "rate", "speed"};
    auto t0 = std::chrono::steady_clock::now();
    std::printf("# Firmware benchmarks (%s)\n", g_elf.c_str());
    try {
        for (const auto& s : sections) {
            if (s == "isr") section_isr(lines);
            if (s == "rate") section_rate();
            if (s == "load") section_load();
            if (s == "speed") section_speed();
            std::fflush(stdout);
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "fw_bench: %s\n", e.what());
        return 1;
    }
    std::printf("\n(fw_bench ran %.0f s)\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return 0;
}
