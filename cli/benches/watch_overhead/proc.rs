//! What /proc tells of the coordinator's CPU time.

/// CPU time of `pid`'s threads, in seconds: all of them, and the journal
/// thread's (SQLite's reads and writes, whose cost on a VM's disk varies by
/// more than watching costs, and which watching never touches).
#[derive(Clone, Copy, Default)]
pub struct Cpu {
    pub total: f64,
    pub journal: f64,
}

impl Cpu {
    /// Everything but the journal thread.
    pub fn outside_journal(&self) -> f64 {
        self.total - self.journal
    }
}

impl std::ops::Sub for Cpu {
    type Output = Cpu;
    fn sub(self, o: Cpu) -> Cpu {
        Cpu { total: self.total - o.total, journal: self.journal - o.journal }
    }
}

pub fn cpu_seconds(pid: u32) -> Cpu {
    let mut cpu = Cpu::default();
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for t in tasks.flatten() {
            let s = std::fs::read_to_string(t.path().join("schedstat")).unwrap_or_default();
            let ns: u64 = s.split_whitespace().next().and_then(|v| v.parse().ok()).unwrap_or(0);
            let secs = ns as f64 * 1e-9;
            cpu.total += secs;
            let name = std::fs::read_to_string(t.path().join("comm")).unwrap_or_default();
            if name.trim() == "farm-journal" {
                cpu.journal += secs;
            }
        }
    }
    cpu
}

/// Where a process's CPU time went, from /proc: system time (in the
/// kernel's 10 ms ticks, so only a median over renders means much),
/// context switches of all its threads and minor page faults.
#[derive(Clone, Copy, Default)]
pub struct Kernel {
    pub sys: f64,
    pub switches: u64,
    pub faults: u64,
}

impl std::ops::Sub for Kernel {
    type Output = Kernel;
    fn sub(self, o: Kernel) -> Kernel {
        Kernel {
            sys: self.sys - o.sys,
            switches: self.switches.saturating_sub(o.switches),
            faults: self.faults.saturating_sub(o.faults),
        }
    }
}

pub fn kernel(pid: u32) -> Kernel {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // The fields after the command's closing parenthesis: minflt is the
    // 10th field of the line, stime the 15th.
    let rest: Vec<&str> =
        stat.rsplit_once(')').map(|(_, r)| r.split_whitespace().collect()).unwrap_or_default();
    let field = |n: usize| rest.get(n - 3).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    let mut switches = 0;
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for t in tasks.flatten() {
            let s = std::fs::read_to_string(t.path().join("status")).unwrap_or_default();
            switches += s
                .lines()
                .filter(|l| l.contains("ctxt_switches:"))
                .filter_map(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
                .sum::<u64>();
        }
    }
    Kernel { sys: field(15) as f64 / 100.0, switches, faults: field(10) }
}
