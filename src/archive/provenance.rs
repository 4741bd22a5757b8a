//! Provenance recorded on every stage version: what ran, on what, with what, when.
use super::data::Attr;
use std::collections::BTreeMap;
use std::time::{SystemTime, UNIX_EPOCH};

/// The software and machine a run happens on.
pub fn environment() -> BTreeMap<String, Attr> {
    let mut m = BTreeMap::new();
    let (a, b, c) = hdf5::library_version();
    m.insert("laydown_version".into(), Attr::Str(env!("CARGO_PKG_VERSION").into()));
    m.insert("git_commit".into(), Attr::Str(env!("LAYDOWN_GIT_COMMIT").into()));
    m.insert("git_dirty".into(), Attr::Str(env!("LAYDOWN_GIT_DIRTY").into()));
    m.insert("rustc_version".into(), Attr::Str(env!("LAYDOWN_RUSTC_VERSION").into()));
    m.insert("hdf5_version".into(), Attr::Str(format!("{a}.{b}.{c}")));
    m.insert("repository".into(), Attr::Str(env!("LAYDOWN_GIT_REMOTE").into()));
    m.insert("cargo_lock_hash".into(), Attr::Str(env!("LAYDOWN_CARGO_LOCK_HASH").into()));
    m.insert("host".into(), Attr::Str(hostname()));
    m.insert("os".into(), Attr::Str(os()));
    m.insert("cpu".into(), Attr::Str(cpu_model()));
    let cwd = std::env::current_dir().map(|d| d.display().to_string()).unwrap_or_else(|_| "unknown".into());
    m.insert("working_directory".into(), Attr::Str(cwd));
    m.insert("threads".into(), Attr::I64(rayon::current_num_threads() as i64));
    m.insert(
        "command_line".into(),
        Attr::Str(std::env::args().map(|a| shell_quote(&a)).collect::<Vec<_>>().join(" ")),
    );
    m
}

fn shell_quote(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:@,+".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Kernel name, release and machine (`uname -srm`).
fn os() -> String {
    // SAFETY: uname fills a zeroed struct of C strings.
    let mut u: libc::utsname = unsafe { std::mem::zeroed() };
    if unsafe { libc::uname(&mut u) } != 0 {
        return std::env::consts::OS.to_string();
    }
    let field = |f: &[libc::c_char]| {
        let bytes: Vec<u8> = f.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
        String::from_utf8_lossy(&bytes).into_owned()
    };
    format!("{} {} {}", field(&u.sysname), field(&u.release), field(&u.machine))
}

/// The CPU model (`model name` in /proc/cpuinfo) and the logical CPUs available.
fn cpu_model() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| t.lines().find(|l| l.starts_with("model name")).and_then(|l| l.split(':').nth(1)).map(|m| m.trim().to_string()))
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cpus = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    format!("{model} ({cpus} logical CPUs available)")
}

pub fn hostname() -> String {
    let mut buf = [0u8; 256];
    let rc = unsafe { libc::gethostname(buf.as_mut_ptr() as *mut libc::c_char, buf.len()) };
    if rc != 0 {
        return "unknown".into();
    }
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    String::from_utf8_lossy(&buf[..end]).into_owned()
}

/// CPU seconds (user + system) used by this process so far, all threads.
pub fn cpu_seconds() -> f64 {
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
    t(usage.ru_utime) + t(usage.ru_stime)
}

/// Current UTC time as ISO 8601 (`2026-11-22T10:04:05Z`).
pub fn utc_now() -> String {
    let secs = SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    utc_from_unix(secs as i64)
}

pub fn utc_from_unix(secs: i64) -> String {
    let days = secs.div_euclid(86400);
    let rem = secs.rem_euclid(86400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, (rem / 60) % 60, rem % 60)
}

#[cfg(test)]
mod tests {
    #[test]
    fn utc_formatting() {
        assert_eq!(super::utc_from_unix(0), "1970-01-01T00:00:00Z");
        assert_eq!(super::utc_from_unix(1_795_000_000), "2026-11-18T11:06:40Z");
        assert_eq!(super::utc_from_unix(951_782_400), "2000-02-29T00:00:00Z");
    }
}
