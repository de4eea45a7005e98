//! The coordinator under valgrind's callgrind: instruction counts that do
//! not depend on the machine's load.

use std::path::PathBuf;
use std::process::{Command, Stdio};

/// The coordinator under callgrind: its process and where it dumps.
pub struct Callgrind {
    pub pid: u32,
    pub dir: PathBuf,
}

impl Callgrind {
    fn control(&self, flag: &str) {
        let ok = Command::new("callgrind_control")
            .args([flag, &self.pid.to_string()])
            .stdout(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "callgrind_control {flag} failed");
    }

    /// Zeroes the counts.
    pub fn zero(&self) {
        self.control("-z");
    }

    /// Dumps the counts since the last zero and returns their total.
    pub fn dump(&self) -> u64 {
        let before = self.dumps();
        self.control("-d");
        let newest = self
            .dumps()
            .into_iter()
            .filter(|p| !before.contains(p))
            .max_by_key(|p| std::fs::metadata(p).and_then(|m| m.modified()).ok())
            .expect("a new callgrind dump");
        let text = std::fs::read_to_string(&newest).expect("read the dump");
        let total = text
            .lines()
            .find_map(|l| l.strip_prefix("totals:").or_else(|| l.strip_prefix("summary:")))
            .and_then(|v| v.split_whitespace().next()?.parse().ok())
            .expect("a total in the dump");
        total
    }

    fn dumps(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(&self.dir)
            .map(|d| d.flatten().map(|e| e.path()).collect())
            .unwrap_or_default();
        v.retain(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("cg.")));
        v
    }
}

/// glibc's settings that keep `memcpy` and `memset` in their vector
/// loops at every size. Callgrind counts each iteration of a `rep movsb`
/// or `rep stosb` (which glibc uses from a few KiB up) as an instruction,
/// so a 1 MiB copy would count 1,048,576 instructions where the CPU moves
/// tens of bytes a cycle; the loops count about 0.1 a byte, in line with
/// what the copy costs.
pub const STRING_LOOPS: &str =
    "glibc.cpu.x86_rep_movsb_threshold=1099511627776:glibc.cpu.x86_rep_stosb_threshold=1099511627776";
