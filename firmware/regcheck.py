#!/usr/bin/env python3
"""Register-level check of the release ELF, on what QEMU cannot show.

    cd firmware && cargo build --release && ./regcheck.py [ELF]

Runs the real ELF from its reset vector on the Unicorn CPU emulator (a
Cortex-M4 with FPU) with the chip's peripherals modelled at register level,
the way silicon answers and not the way QEMU's netduinoplus2 does:

- RCC: reset values of silicon (RCC_CR = 0x83: HSI on and ready, so the
  firmware must take the board path); HSERDY follows HSEON, PLLRDY follows
  PLLON, SWS follows SW; the reset flags in RCC_CSR; the bus clocks computed
  from PLLCFGR and CFGR as RM0090 defines them.
- FLASH: ACR, the option bytes (factory value 0x0FFFAAED, unlocked only by
  the two OPTKEYR keys, programmed on OPTSTRT).
- USART1-3: TXE/TC set, RXNE while a byte waits, a level interrupt from
  (RXNE & RXNEIE) | (TXE & TXEIE) | (TC & TCIE). The line rate on the wire is
  the modelled PCLK / BRR; a byte between two ends whose rates differ by
  more than 2 % arrives as a framing error.
- SysTick (counts the modelled instructions as cycles), NVIC enable/pend,
  SCB ICSR/AIRCR, IWDG key writes. Exceptions are entered and left by this
  script (the handler returns to a trampoline address).
- A fake LMS 2xx on USART2 (answers the bring-up: 20 25, 3B, 20 00, 74, 77,
  20 48, 20 24) and a client on USART1 that switches the host line
  9600 -> 19200 -> 38400 -> 500000 -> 9600, each at the rate the firmware
  has switched to.

Asserts: SYSCLK 168 MHz from the PLL fed by HSE, flash latency 5 with
prefetch and both caches, APB1 42 MHz and APB2 84 MHz; each USART's baud
within 1 % at power-on and after every switch (and the fake peers
understood each other at those rates); SysTick reload for 1 kHz; the
watchdog started and fed from the loop; the brown-out level programmed;
no BKPT 0xAB (semihosting) executed; three scans streamed at 500 kBd on
the board's schedule (one every 26.7 ms, both lines paced at their rate):
every B0 through byte for byte, features after each, one interrupt entry
per byte each way and the handlers' instructions per byte; it prints the
firmware's other work per scan there (instructions outside the pipeline,
asleep excluded), the board-schedule counterpart of the QEMU cycle
estimate's (tools/qemu-icount/realtime.sh); then a HardFault injected from the main
loop leaves a fault record and a system reset request, and the next boot
(RAM kept, RCC_CSR = software reset) reports both on the console. A second
run with a dead crystal must fall back to the PLL on HSI, still 168 MHz.

Needs: python3 -m pip install unicorn (or Debian's python3-unicorn), nm and
llvm-objdump. Ends with "N passed, N failed"; exit status 1 on failure.
"""

import functools
import os
import struct
import subprocess
import sys

from unicorn import (UC_ARCH_ARM, UC_HOOK_BLOCK, UC_HOOK_CODE, UC_HOOK_INTR,
                     UC_MODE_MCLASS, UC_MODE_THUMB, Uc, UcError)
from unicorn import arm_const as A

HERE = os.path.dirname(os.path.abspath(__file__))
ELF = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
    HERE, "target/thumbv7em-none-eabihf/release/lms-firmware")
HSE_HZ = int(os.environ.get("LMS_HSE_HZ", "8000000"))
HSI_HZ = 16_000_000
TRAMPOLINE = 0x080FFF00  # unused flash: handlers "return" here
results = []


def check(name, ok, detail=""):
    results.append(bool(ok))
    print(("ok   " if ok else "FAIL ") + name + (": " + detail if detail else ""), flush=True)


# ---- the ELF ----

def load_segments(path):
    """(address, bytes) of every PT_LOAD segment at its load address."""
    data = open(path, "rb").read()
    assert data[:4] == b"\x7fELF" and data[4] == 1, "32-bit ELF expected"
    phoff, = struct.unpack_from("<I", data, 0x1C)
    phentsize, phnum = struct.unpack_from("<HH", data, 0x2A)
    out = []
    for i in range(phnum):
        p_type, p_offset, _vaddr, p_paddr, p_filesz, _memsz, _flags, _align = \
            struct.unpack_from("<IIIIIIII", data, phoff + i * phentsize)
        if p_type == 1 and p_filesz:
            out.append((p_paddr, data[p_offset:p_offset + p_filesz]))
    return out


def sym_range(name, path=None):
    """(address, size) of a function symbol (thumb bit cleared)."""
    for line in subprocess.run(["nm", "-S", "-C", path or ELF], capture_output=True, text=True,
                               check=True).stdout.splitlines():
        parts = line.split(" ", 3)
        if len(parts) == 4 and parts[3].split("::h")[0] == name and parts[2] in "tT":
            return int(parts[0], 16) & ~1, int(parts[1], 16)
    raise KeyError(name)


def symbols(path):
    out = {}
    for line in subprocess.run(["nm", "-C", path], capture_output=True, text=True, check=True).stdout.splitlines():
        parts = line.split(" ", 2)
        if len(parts) == 3:
            out[parts[2]] = int(parts[0], 16)
    return out


@functools.lru_cache(maxsize=None)
def instructions(path):
    """The code's instructions, disassembled once: (address, mnemonic,
    operands) in address order."""
    dis = subprocess.run(["llvm-objdump", "-d", "--no-show-raw-insn", path], capture_output=True, text=True,
                         check=True).stdout
    out = []
    for line in dis.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].endswith(":"):
            try:
                out.append((int(parts[0][:-1], 16), parts[1], parts[2:]))
            except ValueError:
                continue
    return tuple(out)


def instruction_sites(path):
    """Addresses of `wfi`, of `bkpt #0xab` (semihosting) and of the
    instructions right after a `cpsie i` / `msr primask` (where a pending
    interrupt is taken) in the code."""
    wfi, bkpt, unmask = [], [], []
    after_unmask = False
    for addr, mnemonic, operands in instructions(path):
        if after_unmask:
            unmask.append(addr)
        after_unmask = mnemonic == "cpsie" or (mnemonic == "msr" and operands[:1] == ["primask,"])
        if mnemonic == "wfi":
            wfi.append(addr)
        elif mnemonic == "bkpt" and operands[:1] in (["#171"], ["#0xab"]):
            bkpt.append(addr)
    return wfi, bkpt, unmask


def call_returns(path, target):
    """Return addresses of every `bl` to `target` (a 4-byte `bl`)."""
    return [addr + 4 for addr, mnemonic, operands in instructions(path)
            if mnemonic == "bl" and operands[:1] == [f"0x{target:x}"]]


# ---- LMS framing (PROTOCOL.md section 1) ----

def lms_crc(data):
    crc, prev = 0, 0
    for b in data:
        crc = (((crc & 0x7FFF) << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1) & 0xFFFF
        crc ^= b | (prev << 8)
        prev = b
    return crc & 0xFFFF


def telegram(addr, payload):
    body = bytes([0x02, addr]) + len(payload).to_bytes(2, "little") + payload
    return body + lms_crc(body).to_bytes(2, "little")


class Deframer:
    def __init__(self):
        self.buf = bytearray()

    def feed(self, data):
        self.buf += data
        out = []
        while self.buf:
            if self.buf[0] != 0x02:
                out.append(bytes([self.buf.pop(0)]))
                continue
            if len(self.buf) < 4:
                break
            total = 6 + int.from_bytes(self.buf[2:4], "little")
            if len(self.buf) < total:
                break
            t = bytes(self.buf[:total])
            del self.buf[:total]
            if lms_crc(t[:-2]) == int.from_bytes(t[-2:], "little"):
                out.append(t)
        return out


BAUD_CODES = {0x42: 9600, 0x41: 19200, 0x40: 38400, 0x48: 500000}


# ---- the chip ----

class Usart:
    def __init__(self, name, base, apb):
        self.name, self.base, self.apb = name, base, apb
        self.cr1 = self.cr2 = self.cr3 = self.brr = 0
        self.rx = []           # (byte, framing error) waiting for the line
        self.rx_at = 0         # cycle before which the next byte is not there
        self.rxne = False
        self.dr_in = 0
        self.fe = False
        self.tx = bytearray()
        self.tx_times = []     # cycle at which each byte of `tx` was written
        self.tx_busy_until = 0 # the byte written last is on the wire until then
        self.peer_baud = 9600  # the rate of whoever is on the other end
        self.now = 0

    def sr(self):
        idle = 0xC0 if self.now >= self.tx_busy_until else 0
        return idle | (0x20 if self.rxne else 0) | (0x02 if self.fe and self.rxne else 0)

    def irq_level(self):
        sr = self.sr()
        return bool(sr & self.cr1 & 0xE0)


class Chip:
    def __init__(self, hse_ok=True, csr=0x0E000000, ram=None):
        self.hse_ok = hse_ok
        self.rcc = {0x00: 0x83, 0x04: 0x24003010, 0x08: 0, 0x30: 0x00100000, 0x40: 0, 0x44: 0, 0x74: csr}
        self.flash = {0x00: 0, 0x0C: 0, 0x14: 0x0FFFAAED}
        self.optkeys = []
        self.option_programs = 0
        self.iwdg_keys = []
        self.iwdg = {0x04: 0, 0x08: 0xFFF}
        self.other = {}
        self.usarts = {0x40011000: Usart("USART1", 0x40011000, 2),
                       0x40004400: Usart("USART2", 0x40004400, 1),
                       0x40004800: Usart("USART3", 0x40004800, 1)}
        self.syst = {0x10: 0, 0x14: 0, 0x18: 0}
        self.dwt = {}
        self.nvic_enabled = set()
        self.pending = set()       # exception numbers
        self.reset_requested = False
        self.cycles = 0
        self.tick_at = None
        self.baud_log = []         # (usart, baud) at every BRR write
        self.ram = ram

    # -- clocks as RM0090 derives them from the registers --
    def sysclk(self):
        sws = (self.rcc[0x08] >> 2) & 3
        if sws == 0:
            return HSI_HZ
        if sws == 1:
            return HSE_HZ
        cfg = self.rcc[0x04]
        m, n, p = cfg & 0x3F, (cfg >> 6) & 0x1FF, ((cfg >> 16) & 3) * 2 + 2
        src = HSE_HZ if cfg & (1 << 22) else HSI_HZ
        return src // m * n // p

    def hclk(self):
        hpre = (self.rcc[0x08] >> 4) & 0xF
        div = 1 if hpre < 8 else [2, 4, 8, 16, 64, 128, 256, 512][hpre - 8]
        return self.sysclk() // div

    def pclk(self, apb):
        ppre = (self.rcc[0x08] >> (10 if apb == 1 else 13)) & 7
        div = 1 if ppre < 4 else [2, 4, 8, 16][ppre - 4]
        return self.hclk() // div

    def baud(self, u):
        return self.pclk(u.apb) / u.brr if u.brr else 0.0

    # -- RCC --
    def rcc_read(self, off):
        v = self.rcc.get(off, 0)
        if off == 0x00:
            v &= ~((1 << 1) | (1 << 17) | (1 << 25))
            v |= (v & 1) << 1
            if self.hse_ok:
                v |= (v & (1 << 16)) << 1
            src_ok = (self.rcc[0x04] & (1 << 22) == 0 and v & 1) or \
                     (self.rcc[0x04] & (1 << 22) and v & (1 << 17))
            if src_ok:
                v |= (v & (1 << 24)) << 1
        return v

    def rcc_write(self, off, value):
        if off == 0x08:
            sw = value & 3
            ready = {0: True, 1: bool(self.rcc_read(0) & (1 << 17)), 2: bool(self.rcc_read(0) & (1 << 25))}
            sws = sw if ready.get(sw, False) else (self.rcc[0x08] >> 2) & 3
            value = (value & ~0xC) | (sws << 2)
        elif off == 0x74:
            keep = self.rcc[0x74]
            value = (value & 0x00FFFFFF) | (0 if value & (1 << 24) else keep & 0xFE000000)
        self.rcc[off] = value

    # -- FLASH --
    def flash_write(self, off, value):
        if off == 0x08:
            self.optkeys.append(value)
            if self.optkeys[-2:] == [0x08192A3B, 0x4C5D6E7F]:
                self.flash[0x14] &= ~1
            return
        if off == 0x14:
            if self.flash[0x14] & 1:
                return  # locked
            if value & 2:
                self.option_programs += 1
                value &= ~2
            self.flash[0x14] = value
            return
        self.flash[off] = value

    # -- peripherals window 0x4000_0000 --
    def periph_read(self, addr):
        if 0x40023800 <= addr < 0x40023C00:
            return self.rcc_read(addr - 0x40023800)
        if 0x40023C00 <= addr < 0x40024000:
            return self.flash.get(addr - 0x40023C00, 0)
        if 0x40003000 <= addr < 0x40003400:
            return self.iwdg.get(addr - 0x40003000, 0) if addr != 0x4000300C else 0
        base = addr & ~0x3FF
        if base in self.usarts:
            u, off = self.usarts[base], addr - base
            if off == 0x00:
                return u.sr()
            if off == 0x04:
                v = u.dr_in
                u.rxne = False
                return v
            return {0x08: u.brr, 0x0C: u.cr1, 0x10: u.cr2, 0x14: u.cr3}.get(off, 0)
        return self.other.get(addr, 0)

    def periph_write(self, addr, value):
        if 0x40023800 <= addr < 0x40023C00:
            return self.rcc_write(addr - 0x40023800, value)
        if 0x40023C00 <= addr < 0x40024000:
            return self.flash_write(addr - 0x40023C00, value)
        if 0x40003000 <= addr < 0x40003400:
            if addr == 0x40003000:
                self.iwdg_keys.append(value & 0xFFFF)
            else:
                self.iwdg[addr - 0x40003000] = value
            return
        base = addr & ~0x3FF
        if base in self.usarts:
            u, off = self.usarts[base], addr - base
            if off == 0x04:
                u.tx.append(value & 0xFF)
                u.tx_times.append(self.cycles)
                rate = self.baud(u) or 9600
                u.tx_busy_until = max(self.cycles, u.tx_busy_until) + int(10 * self.hclk() / rate)
            elif off == 0x08:
                u.brr = value
                self.baud_log.append((u.name, self.baud(u)))
            elif off == 0x0C:
                u.cr1 = value
            elif off == 0x10:
                u.cr2 = value
            elif off == 0x14:
                u.cr3 = value
            return
        self.other[addr] = value

    # -- the cycle counter, DWT at 0xE000_1000 (ARMv7-M ARM C1.8) --
    def dwt_read(self, off):
        if off == 0x04:  # CYCCNT: the model's cycles, once enabled
            return self.cycles & 0xFFFFFFFF if self.cycle_counter_on() else 0
        return self.dwt.get(off, 0)  # CTRL: NOCYCCNT (bit 25) clear

    def dwt_write(self, off, value):
        self.dwt[off] = value

    def cycle_counter_on(self):
        # DWT_CTRL.CYCCNTENA and DEMCR.TRCENA (0xE000EDFC, bit 24).
        return self.dwt.get(0x00, 0) & 1 and self.other.get(0xE000EDFC, 0) >> 24 & 1

    # -- system control space 0xE000_E000 --
    def reload(self):
        return self.syst[0x14] & 0xFFFFFF

    def scs_read(self, off):
        if off == 0x18:
            if self.tick_at is None:
                return 0
            return max(0, min(self.reload(), self.tick_at - self.cycles))
        if off in self.syst:
            return self.syst[off]
        if off == 0xD04:
            return (1 << 26) if 15 in self.pending else 0
        if 0x100 <= off < 0x120:
            word = (off - 0x100) * 8
            return sum(1 << (n - word) for n in self.nvic_enabled if word <= n < word + 32)
        return self.other.get(0xE000E000 + off, 0)

    def scs_write(self, off, value):
        if off == 0x10:
            self.syst[0x10] = value
            if value & 1 and self.tick_at is None:
                self.tick_at = self.cycles + self.reload() + 1
        elif off in (0x14, 0x18):
            self.syst[off] = value
            if off == 0x18 and self.syst[0x10] & 1:
                self.tick_at = self.cycles + self.reload() + 1
        elif 0x100 <= off < 0x120:
            for b in range(32):
                if value >> b & 1:
                    self.nvic_enabled.add((off - 0x100) * 8 + b)
        elif 0x180 <= off < 0x1A0:
            for b in range(32):
                if value >> b & 1:
                    self.nvic_enabled.discard((off - 0x180) * 8 + b)
        elif 0x200 <= off < 0x220:
            for b in range(32):
                if value >> b & 1:
                    self.pending.add(16 + (off - 0x200) * 8 + b)
        elif off == 0xD04:
            if value & (1 << 25):
                self.pending.discard(15)
        elif off == 0xD0C:
            if value >> 16 == 0x05FA and value & 4:
                self.reset_requested = True
        else:
            self.other[0xE000E000 + off] = value

    # -- time --
    def advance(self, cycles):
        self.cycles += cycles
        for u in self.usarts.values():
            u.now = self.cycles
        while self.tick_at is not None and self.cycles >= self.tick_at:
            if self.syst[0x10] & 2:
                self.pending.add(15)
            self.tick_at += self.reload() + 1

    def next_event(self):
        times = [self.tick_at] if self.tick_at is not None else []
        times += [u.rx_at for u in self.usarts.values() if u.rx and not u.rxne]
        times += [u.tx_busy_until for u in self.usarts.values() if u.tx_busy_until > self.cycles]
        return min(times) if times else self.cycles + 1_000_000

    def deliver_rx(self):
        for u in self.usarts.values():
            if u.rx and not u.rxne and self.cycles >= u.rx_at:
                b, bad = u.rx.pop(0)
                u.dr_in, u.fe, u.rxne = b, bad, True
                rate = self.baud(u) or u.peer_baud
                u.rx_at = self.cycles + int(10 * self.hclk() / rate)


IRQ = {0x40011000: 16 + 37, 0x40004400: 16 + 38, 0x40004800: 16 + 39}


class Machine:
    """The CPU on the chip model, with exception entry/return done here."""

    def __init__(self, chip, segments, sites, ram_image=None):
        wfi, bkpt, unmask = sites
        self.chip = chip
        uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS)
        uc.ctl_set_cpu_model(A.UC_CPU_ARM_CORTEX_M4)
        uc.mem_map(0x08000000, 0x100000)
        uc.mem_map(0x20000000, 0x20000)
        uc.mem_map(0x10000000, 0x10000)
        for addr, data in segments:
            uc.mem_write(addr, data)
        uc.mem_write(TRAMPOLINE, b"\x00\xbf\x00\xbf")  # nop; nop
        if ram_image is not None:
            uc.mem_write(0x20000000, ram_image)
        uc.mmio_map(0x40000000, 0x80000,
                    lambda _u, off, _s, _d: chip.periph_read(0x40000000 + off), None,
                    lambda _u, off, _s, v, _d: chip.periph_write(0x40000000 + off, v), None)
        uc.mmio_map(0xE0001000, 0x1000,
                    lambda _u, off, _s, _d: chip.dwt_read(off), None,
                    lambda _u, off, _s, v, _d: chip.dwt_write(off, v), None)
        uc.mmio_map(0xE000E000, 0x1000,
                    lambda _u, off, _s, _d: chip.scs_read(off), None,
                    lambda _u, off, _s, v, _d: chip.scs_write(off, v), None)
        self.uc = uc
        self.reason = None
        self.limit = 0
        self.saved = None
        self.current = None
        self.first_block = True
        self.icache = {}
        self.handler_instructions = {}  # exception number -> instructions
        self.handler_entries = {}
        self.slept = 0  # cycles advanced asleep in WFI
        self.semihosting_calls = 0
        self.faults = []
        uc.hook_add(UC_HOOK_BLOCK, self._block)
        for a in wfi:
            uc.hook_add(UC_HOOK_CODE, self._stop("wfi"), begin=a, end=a)
        for a in bkpt:
            uc.hook_add(UC_HOOK_CODE, self._bkpt, begin=a, end=a)
        uc.hook_add(UC_HOOK_CODE, self._stop("return"), begin=TRAMPOLINE, end=TRAMPOLINE)
        for a in unmask:
            uc.hook_add(UC_HOOK_CODE, self._unmasked, begin=a, end=a)
        uc.hook_add(UC_HOOK_INTR, self._intr)
        vectors = uc.mem_read(0x08000000, 8)
        sp, reset = struct.unpack("<II", vectors)
        uc.reg_write(A.UC_ARM_REG_SP, sp)
        self.pc = reset
        self.regs = [getattr(A, f"UC_ARM_REG_R{i}") for i in range(13)] + [
            A.UC_ARM_REG_SP, A.UC_ARM_REG_LR, A.UC_ARM_REG_XPSR, A.UC_ARM_REG_FPSCR] + [
            getattr(A, f"UC_ARM_REG_D{i}") for i in range(16)]

    def instructions(self, addr, size):
        """Thumb instructions in the block at addr (16- or 32-bit each)."""
        n = self.icache.get((addr, size))
        if n is None:
            code = bytes(self.uc.mem_read(addr, size))
            n, i = 0, 0
            while i < size:
                hw = code[i] | code[i + 1] << 8 if i + 1 < size else 0
                i += 4 if hw >> 11 in (0b11101, 0b11110, 0b11111) else 2
                n += 1
            self.icache[(addr, size)] = n
        return n

    def _block(self, uc, addr, size, _d):
        # One cycle per instruction: the time base of this model. A stop
        # requested here happens before the block runs, so the block is
        # counted only when it does run; the first block of a run always
        # runs (else a run that starts past its limit would never move).
        if not self.first_block and (self.chip.cycles >= self.limit or self.chip.reset_requested):
            self.reason = self.reason or "time"
            uc.emu_stop()
            return
        self.first_block = False
        if addr == TRAMPOLINE:
            # The handler's return: stopped at its first instruction, so the
            # block QEMU translated there (the zeroed flash after it) never
            # runs and is not counted.
            return
        n = self.instructions(addr, size)
        self.chip.advance(n)
        if self.saved is not None:
            self.handler_instructions[self.current] = self.handler_instructions.get(self.current, 0) + n


    def _stop(self, why):
        def hook(uc, _addr, _size, _d):
            self.reason = why
            uc.emu_stop()
        return hook

    def _unmasked(self, uc, _addr, _size, _d):
        # PRIMASK may just have been cleared: take a pending interrupt now.
        if self.saved is None and not self.masked() and self.interrupt_due() is not None:
            self.reason = "unmasked"
            uc.emu_stop()

    def _bkpt(self, uc, addr, _size, _d):
        self.semihosting_calls += 1
        self.reason = f"semihosting BKPT 0xAB at {addr:#x}"
        uc.emu_stop()

    def _intr(self, uc, intno, _d):
        self.faults.append((intno, uc.reg_read(A.UC_ARM_REG_PC)))
        self.reason = f"CPU exception {intno} at {uc.reg_read(A.UC_ARM_REG_PC):#x}"
        uc.emu_stop()

    def vector(self, n):
        return struct.unpack("<I", self.uc.mem_read(0x08000000 + 4 * n, 4))[0]

    def enter(self, n, frame=None):
        """Exception entry for number n (handler returns to TRAMPOLINE)."""
        uc = self.uc
        self.saved = ([uc.reg_read(r) for r in self.regs], self.pc)
        sp = (uc.reg_read(A.UC_ARM_REG_SP) - 0x20) & ~7
        if frame is not None:
            uc.mem_write(sp, struct.pack("<8I", *frame))
        uc.reg_write(A.UC_ARM_REG_SP, sp)
        uc.reg_write(A.UC_ARM_REG_LR, TRAMPOLINE | 1 if frame is None else 0xFFFFFFF9)
        self.chip.pending.discard(n)
        self.current = n
        self.handler_entries[n] = self.handler_entries.get(n, 0) + 1
        self.pc = self.vector(n)

    def leave(self):
        regs, pc = self.saved
        for r, v in zip(self.regs, regs):
            self.uc.reg_write(r, v)
        self.pc = pc
        self.saved = None

    def in_it_block(self):
        """Stopped inside an IT block (ITSTATE in xPSR bits 26:25, 15:10)?
        Exception entry here would run the handler under the IT condition."""
        xpsr = self.uc.reg_read(A.UC_ARM_REG_XPSR)
        return bool((xpsr >> 25) & 3 or (xpsr >> 10) & 0x3F)

    def masked(self):
        return bool(self.uc.reg_read(A.UC_ARM_REG_PRIMASK) & 1)

    def interrupt_due(self):
        """The pending, enabled exception to take (ignoring PRIMASK)."""
        if self.saved is not None:
            return None
        for base, u in self.chip.usarts.items():
            if u.irq_level() and IRQ[base] - 16 in self.chip.nvic_enabled:
                self.chip.pending.add(IRQ[base])
        due = [n for n in self.chip.pending if n == 15 or n - 16 in self.chip.nvic_enabled]
        return min(due) if due else None

    def run(self, until, max_cycles=3_000_000_000):
        """Run until `until()` is true, a fault, a semihosting call or a reset request."""
        chip = self.chip
        while not until():
            if chip.cycles > max_cycles:
                return "cycle budget exhausted"
            if chip.reset_requested:
                return "reset requested"
            chip.deliver_rx()
            n = self.interrupt_due()
            soon = False
            if n is not None and not self.masked():
                if self.in_it_block():
                    soon = True  # hardware would finish the IT block's state; take it at the next block
                else:
                    self.enter(n)
            self.reason = None
            self.limit = chip.cycles if soon else min(chip.next_event(), chip.cycles + 20_000)
            self.first_block = True
            try:
                self.uc.emu_start(self.pc | 1, 0xFFFFFFFF)
            except UcError as e:
                return f"emulation error {e} at {self.uc.reg_read(A.UC_ARM_REG_PC):#x}"
            self.pc = self.uc.reg_read(A.UC_ARM_REG_PC)
            if self.reason == "wfi":
                # Sleep to the next event unless an interrupt is already pending.
                if self.interrupt_due() is None:
                    idle = max(0, chip.next_event() - chip.cycles)
                    chip.advance(idle)
                    self.slept += idle
                self.pc += 2
            elif self.reason == "return":
                self.leave()
            elif self.reason not in ("time", "unmasked", None):
                return self.reason
        return None


# ---- the peers ----

class FakeLms:
    """The LMS 2xx on USART2: ACK and a reply for each request."""

    def __init__(self, chip):
        self.u = chip.usarts[0x40004400]
        self.chip = chip
        self.deframer = Deframer()
        self.requests = []
        self.bad_rate = 0
        self.streaming = False
        self.config = bytearray(34)
        self.switch_to = None

    def poll(self):
        u = self.u
        if not u.tx:
            return
        data, u.tx[:] = bytes(u.tx), b""
        if abs(self.chip.baud(u) / u.peer_baud - 1) > 0.02:
            self.bad_rate += len(data)
            return
        for t in self.deframer.feed(data):
            if len(t) < 7:
                continue
            req = t[4:-2]
            self.requests.append(req.hex())
            cmd = req[0]
            reply = {0x20: bytes([0xA0, 0x00]), 0x3B: bytes([0xBB, 0x01]) + req[1:5],
                     0x74: bytes([0xF4]) + self.config}.get(cmd)
            if cmd == 0x77:
                self.config[:] = req[1:35]
                reply = bytes([0xF7, 0x01]) + self.config
            self.send(b"\x06" + telegram(0x80, (reply or bytes([0x92])) + b"\x10"))
            if cmd == 0x20 and req[1] in BAUD_CODES:
                u.peer_baud = BAUD_CODES[req[1]]
            self.streaming = cmd == 0x20 and req[1] == 0x24

    def send(self, data):
        ok = abs(self.chip.baud(self.u) / self.u.peer_baud - 1) <= 0.02
        self.u.rx += [(b, not ok) for b in data]


class Client:
    """The robot's computer on USART1: asks for each rate in turn, and
    switches itself after the A0 reply, as an LMS client does."""

    def __init__(self, chip, rates):
        self.u = chip.usarts[0x40011000]
        self.chip = chip
        self.rates = list(rates)
        self.deframer = Deframer()
        self.switched = []   # (asked, BRR-derived baud once the firmware switched)
        self.waiting = None  # asked, reply not yet seen
        self.expect = None   # reply seen, firmware not yet switched
        self.garbled = 0

    def poll(self):
        u, chip = self.u, self.chip
        if u.tx:
            data, u.tx[:] = bytes(u.tx), b""
            if abs(chip.baud(u) / u.peer_baud - 1) > 0.02:
                self.garbled += len(data)
            else:
                for t in self.deframer.feed(data):
                    if self.waiting and len(t) > 5 and t[4] == 0xA0:
                        u.peer_baud = self.expect = self.waiting
                        self.waiting = None
        if self.expect and not u.tx and within(chip.baud(u), self.expect, 0.02):
            self.switched.append((self.expect, chip.baud(u)))
            self.expect = None
        if self.waiting is None and self.expect is None and self.rates and not u.rx:
            rate = self.rates.pop(0)
            code = {v: k for k, v in BAUD_CODES.items()}[rate]
            ok = abs(chip.baud(u) / u.peer_baud - 1) <= 0.02
            u.rx += [(b, not ok) for b in telegram(0x00, bytes([0x20, code]))]
            self.waiting = rate

    def done(self):
        return not self.rates and self.waiting is None and self.expect is None


def within(baud, want, tol=0.01):
    return baud and abs(baud / want - 1) <= tol


def boot_and_bring_up(segments, syms, sites):
    chip = Chip()
    m = Machine(chip, segments, sites)
    lms = FakeLms(chip)
    host = Client(chip, [19200, 38400, 9600, 500000])  # keep in step with `asked` below

    def ready():
        return chip.syst[0x14] != 0 and chip.usarts[0x40004800].cr1 & 0x2000 and chip.nvic_enabled
    why = m.run(ready)
    check("boot reaches the loop set-up", why is None, why or "")
    u1, u2, u3 = (chip.usarts[a] for a in (0x40011000, 0x40004400, 0x40004800))
    rcc = chip.rcc
    cfg = rcc[0x04]
    check("SYSCLK 168 MHz from the PLL on HSE", chip.sysclk() == 168_000_000 and (rcc[0x08] >> 2) & 3 == 2
          and cfg & (1 << 22), f"PLLCFGR={cfg:#010x} (M={cfg & 63} N={(cfg >> 6) & 511} "
          f"P={((cfg >> 16) & 3) * 2 + 2} Q={(cfg >> 24) & 15}), CFGR={rcc[0x08]:#010x}, HSE {HSE_HZ} Hz")
    check("USB clock 48 MHz (PLLQ)", (HSE_HZ // (cfg & 63) * ((cfg >> 6) & 511)) // ((cfg >> 24) & 15) == 48_000_000)
    acr = chip.flash[0x00]
    check("flash latency 5, prefetch, I- and D-cache", acr & 7 == 5 and acr & 0x700 == 0x700, f"ACR={acr:#x}")
    check("AHB 168, APB1 42, APB2 84 MHz", (chip.hclk(), chip.pclk(1), chip.pclk(2)) ==
          (168_000_000, 42_000_000, 84_000_000), f"{chip.hclk()} / {chip.pclk(1)} / {chip.pclk(2)} Hz")
    for u, want in ((u1, 9600), (u2, 9600), (u3, 115200)):
        check(f"{u.name} at {want} Bd at power-on (within 1 %)", within(chip.baud(u), want),
              f"BRR={u.brr:#x} -> {chip.baud(u):.1f} Bd from {chip.pclk(u.apb)} Hz")
    rvr, csr = chip.syst[0x14], chip.syst[0x10]
    check("SysTick 1 kHz from the core clock", rvr + 1 == chip.hclk() // 1000 and csr & 7 == 7,
          f"RVR={rvr} CSR={csr:#x}")
    keys = chip.iwdg_keys
    check("watchdog started", 0x5555 in keys and 0xCCCC in keys and chip.iwdg[0x08] > 0,
          f"keys {[hex(k) for k in keys[:4]]}, PR={chip.iwdg[0x04]} RLR={chip.iwdg[0x08]}")
    opt = chip.flash[0x14]
    check("brown-out level 3 programmed once, option bytes locked", (opt >> 2) & 3 == 0 and opt & 1
          and chip.option_programs == 1 and (opt & ~0x0E) == (0x0FFFAAED & ~0x0E),
          f"OPTCR={opt:#010x}, {chip.option_programs} programming(s)")
    print(f"     boot: {chip.cycles} cycles (modelled) to the loop")

    # The bring-up and the host's baud switches, both peers at their rates.
    def progress():
        lms.poll()
        host.poll()
        return lms.streaming and host.done()
    why = m.run(progress, max_cycles=chip.cycles + 2_000_000_000)
    check("sensor bring-up to streaming (fake LMS)", lms.streaming and why is None,
          (why or "") + " requests: " + " ".join(lms.requests))
    sensor_switch = [b for n, b in chip.baud_log if n == "USART2"]
    check("sensor line switched to 500 kBd exactly", sensor_switch and sensor_switch[-1] == 500_000
          and lms.bad_rate == 0, f"USART2 rates written: {[round(b) for b in sensor_switch]}, "
          f"{lms.bad_rate} bytes at a wrong rate")
    asked = [19200, 38400, 9600, 500000]
    got = dict(host.switched)
    for rate in asked:
        code = [k for k, v in BAUD_CODES.items() if v == rate][0]
        check(f"host line after 20 {code:02X}: {rate} Bd within 1 %", rate in got and within(got[rate], rate),
              f"{got.get(rate) and round(got[rate], 1)} Bd; USART1 rates written: "
              f"{[round(b) for n, b in chip.baud_log if n == 'USART1']}")
    check("host replies understood at every rate", host.garbled == 0 and host.done(),
          f"{host.garbled} bytes at a wrong rate")
    feeds = chip.iwdg_keys.count(0xAAAA)
    check("watchdog fed from the loop", feeds > 10, f"{feeds} feeds in {chip.cycles / 168e6:.2f} s (modelled)")
    check("no semihosting on the board path", m.semihosting_calls == 0 and not m.faults,
          f"{len(sites[1])} BKPT 0xAB sites in the ELF, {m.semihosting_calls} executed, CPU exceptions {m.faults}")
    stream(m, chip, lms, host, syms)
    return m, chip


def room_scans(n):
    """The first `n` 361-value B0 telegrams (180 deg / 0.5 deg, mm) of a
    room: the very scans qemu-smoke.py sends (its `room_scan`, loaded from
    that script)."""
    import importlib.util
    here = os.path.dirname(os.path.abspath(__file__))
    spec = importlib.util.spec_from_file_location("qemu_smoke", os.path.join(here, "qemu-smoke.py"))
    smoke = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(smoke)
    return [smoke.room_scan(k) for k in range(n)]


def stream(m, chip, lms, host, syms, n_scans=3):
    """Both lines at 500 kBd: the LMS streams a scan every 26.7 ms, the
    client has continuous output on. Measures the receive interrupt's cost
    per byte and how long the host line is still sending after the loop has
    finished a scan (the overlap of computation and transmission)."""
    u1, u2 = chip.usarts[0x40011000], chip.usarts[0x40004400]
    # Features are opt-in on the host line (56 01), then continuous output.
    u1.rx += [(b, False) for b in telegram(0x00, bytes([0x56, 0x01])) + telegram(0x00, bytes([0x20, 0x24]))]
    got, seq = [], []
    ends = []
    end_addr = syms.get("scan_end", 0) & ~1
    m.uc.hook_add(UC_HOOK_CODE, lambda *_: ends.append(chip.cycles), begin=end_addr, end=end_addr)
    begins = []
    begin_addr = syms.get("scan_begin", 0) & ~1
    m.uc.hook_add(UC_HOOK_CODE, lambda *_: begins.append(chip.cycles), begin=begin_addr, end=begin_addr)
    m.uc.ctl_flush_tb()
    scans = room_scans(n_scans)
    period = int(0.0267 * 168e6)
    t0 = chip.cycles + 2_000_000
    sent = [0]
    # The pipeline's instructions (Extractor::run, entry to return, the
    # interrupts that arrive meanwhile included: as tools/qemu-icount counts
    # them), to separate the firmware's other work from it.
    run_at, _ = sym_range("lms_core::pipeline::extractor::Extractor::run")
    pipe = {"in": None, "total": 0}

    def run_entry(*_):
        if pipe["in"] is None:
            pipe["in"] = chip.cycles

    def run_return(*_):
        if pipe["in"] is not None:
            pipe["total"] += chip.cycles - pipe["in"]
            pipe["in"] = None
    m.uc.hook_add(UC_HOOK_CODE, run_entry, begin=run_at, end=run_at)
    for ret in call_returns(ELF, run_at):
        m.uc.hook_add(UC_HOOK_CODE, run_return, begin=ret, end=ret)
    window = {}
    m.uc.ctl_flush_tb()  # code translated before the hooks existed
    last_byte = []

    def progress():
        k = sent[0]
        if k < n_scans and chip.cycles >= t0 + k * period:
            if k == 0:
                window.update(cycles=chip.cycles, slept=m.slept, pipe=pipe["total"],
                              entries=dict(m.handler_entries), insns=dict(m.handler_instructions))
            lms.send(scans[k])
            sent[0] += 1
        lms.poll()
        if u1.tx:
            data, times = bytes(u1.tx), list(u1.tx_times)
            u1.tx[:], u1.tx_times[:] = b"", []
            if window:
                window["sent"] = window.get("sent", 0) + len(data)
            for i, t in enumerate(host.deframer.feed(data)):
                if len(t) > 5:
                    seq.append(t[4])
                    if t[4] == 0xB0:
                        got.append(t)
                    if t[4] == 0xD0:
                        last_byte.append(times[-1] + int(10 * 168e6 / 500_000))
        return len([c for c in seq if c == 0xD0]) >= n_scans
    why = m.run(progress, max_cycles=chip.cycles + 20 * period)
    check(f"{n_scans} scans streamed at 500 kBd: every B0 passed through byte for byte", why is None and got == scans,
          f"{len(got)} of {n_scans} B0" + (f"; {why}" if why else ""))
    def entries(n):
        """Entries of exception `n` a scan in the window."""
        return (m.handler_entries.get(n, 0) - window["entries"].get(n, 0)) / n_scans

    def insns(n):
        """Instructions of exception `n`'s handler a scan in the window."""
        return (m.handler_instructions.get(n, 0) - window["insns"].get(n, 0)) / n_scans
    pipeline = (pipe["total"] - window["pipe"]) / n_scans
    other = (chip.cycles - window["cycles"] - (m.slept - window["slept"])) / n_scans - pipeline
    print(f"     per scan on the board's schedule: pipeline {pipeline / 1e6:.3f} M instructions, other work "
          f"{other / 1e6:.3f} M instructions and {sum(entries(n) for n in m.handler_entries):.0f} exceptions")
    groups = " ".join(f"{c:02X}" for c in seq)
    check("features after every scan (D4 D3 D1 D2 D0)", seq.count(0xD0) == n_scans, groups[:80])
    # Whole handlers, everything they call included (one entry per byte).
    rx = insns(54) / max(1, entries(54))
    tx = insns(53) / max(1, entries(53))
    check("receive interrupt cost per byte (USART2, 500 kBd)", 0 < rx < 150,
          f"{rx:.1f} instructions per byte ({entries(54):.0f} entries a scan, one per byte) = "
          f"{rx * 50_000 / 168e6 * 100:.2f} % of 168 MHz at 50 000 bytes/s, + 12 cycles entry and 12 exit each")
    sent = window.get("sent", 0) / n_scans
    check("transmit interrupt: one entry per byte sent, as on silicon (USART1, 500 kBd)",
          0 < tx < 150 and abs(entries(53) - sent) <= 0.02 * sent,
          f"{entries(53):.0f} entries for {sent:.0f} bytes a scan, {tx:.1f} instructions each")
    overlap = [(lb - e) / 168e3 for e, lb in zip(ends[-n_scans:], last_byte)]
    check("the loop finishes each scan while the host line is still sending", overlap and min(overlap) > 5,
          "host line busy " + ", ".join(f"{o:.1f}" for o in overlap) + " ms after scan_end")
    # The console's scan cycles, read from the cycle counter (the model's
    # cycles here): the polls that carried scans, as measured between the
    # markers by the model.
    polls = [e - max(b for b in begins if b <= e) for e in ends[-n_scans:]]
    console = chip.usarts[0x40004800]
    console.tx[:] = b""
    console.rx.append((ord("s"), False))
    console.peer_baud = 115200
    why = m.run(lambda: b"\n" in console.tx, max_cycles=chip.cycles + 200_000_000)
    fields = dict(kv.split("=", 1) for kv in console.tx.decode(errors="replace").split() if "=" in kv)
    last, worst = int(fields.get("scan_poll_cycles_last", 0)), int(fields.get("scan_poll_cycles_max", 0))
    check("the cycle counter on: the console's poll cycles match the model's",
          why is None and fields.get("cycle_counter") == "1" and polls and abs(last - polls[-1]) < 0.01 * polls[-1]
          and max(polls) <= worst < period,
          f"scan_poll_cycles_last={last} (model {polls[-1] if polls else 0}), max={worst} "
          f"(model {max(polls) if polls else 0})" + (f"; {why}" if why else ""))


def fault_and_reboot(m, chip, segments, syms, sites):
    """HardFault from the loop -> record + reset request; next boot reports it."""
    fake_pc, fake_lr = 0x08001234, 0x08005679
    frame = [0, 0, 0, 0, 0, fake_lr, fake_pc, 0x01000000]
    m.enter(3, frame)
    why = m.run(lambda: False, max_cycles=chip.cycles + 50_000_000)
    check("HardFault ends in a system reset request (AIRCR)", why == "reset requested" and m.semihosting_calls == 0,
          why or "")
    rec_addr = syms.get("lms_firmware::fault::RECORD")
    rec = struct.unpack("<6I", m.uc.mem_read(rec_addr, 24)) if rec_addr else (0,) * 6
    check("fault record in .uninit", rec[0] == 0x4C4D5346 and rec[1:4] == (2, fake_pc, fake_lr),
          f"at {rec_addr:#x}: magic={rec[0]:#x} cause={rec[1]} pc={rec[2]:#x} lr={rec[3]:#x}")
    ram = bytes(m.uc.mem_read(0x20000000, 0x20000))
    chip2 = Chip(csr=1 << 28, ram=ram)  # SFTRSTF
    m2 = Machine(chip2, segments, sites, ram_image=ram)
    console = chip2.usarts[0x40004800]
    sent = []

    def answered():
        if console.cr1 & 0x2000 and chip2.nvic_enabled and not sent:
            console.rx.append((ord("s"), False))
            console.peer_baud = 115200
            sent.append(1)
        return b"\n" in console.tx
    why = m2.run(answered, max_cycles=2_000_000_000)
    line = console.tx.decode(errors="replace")
    fields = dict(kv.split("=", 1) for kv in line.split() if "=" in kv)
    check("next boot reports reset cause and last fault on the console",
          why is None and fields.get("reset_flags") == str(1 << 3) and fields.get("fault_cause") == "2"
          and fields.get("fault_pc") == str(fake_pc) and fields.get("fault_lr") == str(fake_lr),
          " ".join(f"{k}={fields.get(k)}" for k in ("reset_flags", "fault_cause", "fault_pc", "fault_lr")) or why)
    check("record cleared after it was reported", struct.unpack("<I", m2.uc.mem_read(rec_addr, 4))[0] == 0)
    # The host reads the same with the counters request 55 -> D5.
    host = chip2.usarts[0x40011000]
    host.tx[:] = b""
    host.rx += [(b, False) for b in telegram(0x00, bytes([0x55]))]
    d5 = []

    def counters():
        d5.extend(t for t in Deframer().feed(bytes(host.tx)) if len(t) > 5 and t[4] == 0xD5)
        return bool(d5)
    why = m2.run(counters, max_cycles=chip2.cycles + 500_000_000)
    fields = struct.unpack("<16I", d5[0][5:69]) if d5 and len(d5[0]) >= 71 else (0,) * 16
    check("the counters telegram D5 carries reset flags and the last fault", why is None and
          fields[12:16] == (1 << 3, 2, fake_pc, fake_lr),
          f"D5 boot fields {[hex(v) for v in fields[12:16]]}" + (f"; {why}" if why else ""))
    check("no semihosting on the reboot", m2.semihosting_calls == 0)


def dead_crystal(segments, sites):
    chip = Chip(hse_ok=False)
    m = Machine(chip, segments, sites)
    why = m.run(lambda: chip.syst[0x14] != 0, max_cycles=200_000_000)
    cfg = chip.rcc[0x04]
    check("dead crystal: PLL on HSI, still 168 MHz, bounded wait", why is None and chip.sysclk() == 168_000_000
          and not cfg & (1 << 22) and chip.usarts[0x40004400].brr and within(chip.baud(chip.usarts[0x40004400]), 9600),
          f"PLLCFGR={cfg:#010x}, SYSCLK {chip.sysclk()} Hz, HSE given up after {chip.cycles} cycles")


def main():
    segments = load_segments(ELF)
    syms = symbols(ELF)
    sites = instruction_sites(ELF)
    m, chip = boot_and_bring_up(segments, syms, sites)
    fault_and_reboot(m, chip, segments, syms, sites)
    dead_crystal(segments, sites)
    print(f"{sum(results)} passed, {len(results) - sum(results)} failed")
    return 0 if all(results) else 1


if __name__ == "__main__":
    sys.exit(main())
