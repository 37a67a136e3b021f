//! Running a test inside a private network namespace with only loopback, so that no DDS packet
//! of a test ever reaches the machine's real interfaces.
//!
//! The test binary re-executes itself for one test, with `ADVISE_TEST_NETNS=1`, in a child that
//! (before `exec`, in `pre_exec`) unshares its network namespace (and its user namespace when not
//! root), brings `lo` up with the MULTICAST flag (SIOCSIFFLAGS) and routes 224.0.0.0/4 on `lo`
//! (SIOCADDRT), which DDS discovery needs. No `ip` or `unshare` command is used. A machine where
//! this is not allowed skips the test with a printed reason.

#![allow(dead_code)]

use std::io;
use std::os::unix::process::CommandExt;
use std::process::{Child, Command};
use std::time::Duration;

pub const ENV: &str = "ADVISE_TEST_NETNS";

/// Whether this process is the namespaced child.
pub fn inside() -> bool {
    std::env::var_os(ENV).is_some_and(|v| v == "1")
}

/// The network interfaces this process sees.
pub fn interfaces() -> Vec<String> {
    let mut out = Vec::new();
    // SAFETY: if_nameindex returns a list terminated by a zero index, freed below.
    unsafe {
        let list = libc::if_nameindex();
        if list.is_null() {
            return out;
        }
        let mut p = list;
        while (*p).if_index != 0 {
            let name = std::ffi::CStr::from_ptr((*p).if_name);
            out.push(name.to_string_lossy().into_owned());
            p = p.add(1);
        }
        libc::if_freenameindex(list);
    }
    out
}

/// `struct rtentry` of <net/route.h> (glibc and musl share the layout on Linux).
#[repr(C)]
struct RtEntry {
    rt_pad1: libc::c_ulong,
    rt_dst: libc::sockaddr,
    rt_gateway: libc::sockaddr,
    rt_genmask: libc::sockaddr,
    rt_flags: libc::c_ushort,
    rt_pad2: libc::c_short,
    rt_pad3: libc::c_ulong,
    rt_tos: libc::c_uchar,
    rt_class: libc::c_uchar,
    #[cfg(target_pointer_width = "64")]
    rt_pad4: [libc::c_short; 3],
    #[cfg(not(target_pointer_width = "64"))]
    rt_pad4: [libc::c_short; 1],
    rt_metric: libc::c_short,
    rt_dev: *mut libc::c_char,
    rt_mtu: libc::c_ulong,
    rt_window: libc::c_ulong,
    rt_irtt: libc::c_ushort,
}

const SIOCADDRT: libc::c_ulong = 0x890B;
const RTF_UP: libc::c_ushort = 0x0001;

fn ipv4(a: [u8; 4]) -> libc::sockaddr {
    let sin = libc::sockaddr_in {
        sin_family: libc::AF_INET as libc::sa_family_t,
        sin_port: 0,
        sin_addr: libc::in_addr {
            s_addr: u32::from_ne_bytes(a),
        },
        sin_zero: [0; 8],
    };
    // SAFETY: sockaddr_in and sockaddr have the same size on Linux.
    unsafe { std::mem::transmute::<libc::sockaddr_in, libc::sockaddr>(sin) }
}

/// In the forked child before exec: a new network namespace, `lo` up with multicast, and (when
/// `multicast`) the multicast route on `lo`. Only async-signal-safe calls.
fn isolate(multicast: bool) -> io::Result<()> {
    // SAFETY: plain system calls on values owned here.
    unsafe {
        let mut flags = libc::CLONE_NEWNET;
        if libc::geteuid() != 0 {
            flags |= libc::CLONE_NEWUSER;
        }
        if libc::unshare(flags) != 0 {
            return Err(io::Error::last_os_error());
        }
        let fd = libc::socket(libc::AF_INET, libc::SOCK_DGRAM, 0);
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        let mut req: libc::ifreq = std::mem::zeroed();
        for (i, b) in b"lo\0".iter().enumerate() {
            req.ifr_name[i] = *b as libc::c_char;
        }
        req.ifr_ifru.ifru_flags =
            (libc::IFF_UP | libc::IFF_RUNNING | libc::IFF_LOOPBACK | libc::IFF_MULTICAST)
                as libc::c_short;
        if libc::ioctl(fd, libc::SIOCSIFFLAGS as _, &req) != 0 {
            let e = io::Error::last_os_error();
            libc::close(fd);
            return Err(e);
        }
        if !multicast {
            libc::close(fd);
            return Ok(());
        }
        let mut route: RtEntry = std::mem::zeroed();
        route.rt_dst = ipv4([224, 0, 0, 0]);
        route.rt_genmask = ipv4([240, 0, 0, 0]);
        route.rt_gateway = ipv4([0, 0, 0, 0]);
        route.rt_flags = RTF_UP;
        route.rt_dev = c"lo".as_ptr() as *mut libc::c_char;
        if libc::ioctl(fd, SIOCADDRT as _, &route) != 0 {
            let e = io::Error::last_os_error();
            libc::close(fd);
            return Err(e);
        }
        libc::close(fd);
    }
    Ok(())
}

/// Spawn `cmd` in a fresh private network namespace (see the module docs).
pub fn spawn_isolated(cmd: Command) -> io::Result<Child> {
    spawn_isolated_with(cmd, true)
}

/// [`spawn_isolated`], with the multicast route on loopback or without it (`multicast`).
pub fn spawn_isolated_with(mut cmd: Command, multicast: bool) -> io::Result<Child> {
    cmd.env(ENV, "1");
    // SAFETY: `isolate` makes only async-signal-safe system calls.
    unsafe {
        cmd.pre_exec(move || isolate(multicast));
    }
    cmd.spawn()
}

/// Whether the namespace has a route for multicast (224.0.0.0/4), by `/proc/net/route`.
pub fn has_multicast_route() -> bool {
    std::fs::read_to_string("/proc/net/route").is_ok_and(|t| {
        t.lines()
            .skip(1)
            .any(|l| l.split_whitespace().nth(1) == Some("000000E0"))
    })
}

pub use super::python::wait_bounded;

/// In a test: `true` when the body should run here (this is the namespaced child). Otherwise this
/// runs the test `name` again in a private namespace with `env`, checks it passed, and returns
/// `false`; it prints why and returns `false` when no namespace can be made.
pub fn run_isolated(name: &str, env: &[(&str, String)], limit: Duration) -> bool {
    run_isolated_with(name, env, limit, true)
}

/// [`run_isolated`], with the multicast route on loopback or without it (`multicast`).
pub fn run_isolated_with(
    name: &str,
    env: &[(&str, String)],
    limit: Duration,
    multicast: bool,
) -> bool {
    if inside() {
        let seen = interfaces();
        assert_eq!(seen, ["lo"], "the namespaced test sees other interfaces");
        return true;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let mut cmd = Command::new(exe);
    cmd.args([name, "--exact", "--nocapture", "--test-threads=1"]);
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = match spawn_isolated_with(cmd, multicast) {
        Ok(c) => c,
        Err(e) => {
            eprintln!(
                "skipping {name}: cannot create a private network namespace with only loopback ({e}); DDS tests never use the real network"
            );
            return false;
        }
    };
    match wait_bounded(&mut child, limit) {
        Some(status) => assert!(status.success(), "{name} failed in its namespace: {status}"),
        None => panic!("{name} took longer than {limit:?} in its namespace and was killed"),
    }
    false
}
