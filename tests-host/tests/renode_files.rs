//! The Renode bench (`renode/`) cannot run here, so this keeps what can be checked without
//! Renode true of its files: every file a script, platform or Robot test names exists, every
//! firmware binary it names is one `cargo firmware` builds, every peripheral a script or test
//! addresses (`sysbus.spi1.sensor`) is declared in the platform its machine loads, nothing is
//! fetched from the network, every machine has a unique ID of its own, and the serial numbers
//! the Robot tests expect are the ones those IDs give.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use od_core::storage::crc::crc32;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn renode() -> PathBuf {
    root().join("renode")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// What the files use of Renode's stock `platforms/cpus/stm32f103.repl` (renode 06854d4d):
/// its peripherals, each registered on `sysbus`.
const STOCK_STM32F103: &[&str] = &[
    "cpu",
    "nvic",
    "exti",
    "afio",
    "flash",
    "sram",
    "fsmcBank1",
    "dma1",
    "dma2",
    "gpioPortA",
    "gpioPortB",
    "gpioPortC",
    "gpioPortD",
    "gpioPortE",
    "gpioPortF",
    "gpioPortG",
    "timer1",
    "timer2",
    "timer3",
    "timer4",
    "timer5",
    "timer6",
    "timer7",
    "timer8",
    "usart1",
    "usart2",
    "usart3",
    "i2c1",
    "i2c2",
];

/// The lines of a file without its comments (`//` in a platform, `#` in a script or test).
fn code_lines<'a>(text: &'a str, comment: &'a str) -> impl Iterator<Item = &'a str> + 'a {
    text.lines().map(move |l| l.split_once(comment).map_or(l, |(code, _)| code))
}

/// A platform with everything it builds on (`using`): each peripheral with the one it is
/// registered on.
fn platform(file: &str) -> BTreeMap<String, String> {
    let path = renode().join(file);
    let text = read(&path);
    let mut declared = BTreeMap::new();
    let mut in_script = false;
    for line in code_lines(&text, "//") {
        // A Python peripheral's script ('''...''') is no platform description.
        if line.matches("'''").count() % 2 == 1 {
            in_script = !in_script;
            continue;
        }
        if in_script {
            continue;
        }
        if let Some(rest) = line.strip_prefix("using ") {
            let used = rest.trim().trim_matches('"');
            if used == "platforms/cpus/stm32f103.repl" {
                for p in STOCK_STM32F103 {
                    declared.insert(p.to_string(), "sysbus".to_string());
                }
            } else {
                let used = used.strip_prefix("./").unwrap_or_else(|| panic!("{file}: using {used}"));
                assert!(renode().join(used).is_file(), "{file}: using renode/{used}, which is missing");
                declared.extend(platform(used));
            }
            continue;
        }
        // "name: Type @ parent ..." or "name: @ parent ..." at the start of a line declares (or
        // moves) a peripheral; "name:" alone updates one.
        if line.starts_with(' ') || line.is_empty() {
            continue;
        }
        let Some((name, rest)) = line.split_once(':') else { continue };
        if let Some((_, at)) = rest.split_once('@') {
            let parent = at.split_whitespace().next().unwrap_or("").trim_start_matches('{');
            declared.insert(name.trim().to_string(), parent.to_string());
        } else {
            let name = name.trim();
            assert!(name == "sysbus" || declared.contains_key(name), "{file}: {name} updated before it is declared");
        }
    }
    declared
}

/// Does `sysbus.a.b.c` name a peripheral of `platform`: `a` on sysbus, `b` on `a`, `c` on `b`?
fn resolves(platform: &BTreeMap<String, String>, path: &str) -> bool {
    let mut parent = "sysbus";
    for name in path.split('.').skip(1) {
        if platform.get(name).map(String::as_str) != Some(parent) {
            return false;
        }
        parent = name;
    }
    true
}

/// The peripheral paths (`sysbus.x.y`) a line names.
fn peripheral_paths(line: &str) -> Vec<String> {
    let mut paths = Vec::new();
    let mut rest = line;
    while let Some(k) = rest.find("sysbus.") {
        let tail = &rest[k..];
        let end = tail.find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '_')).unwrap_or(tail.len());
        paths.push(tail[..end].trim_end_matches('.').to_string());
        rest = &tail[end..];
    }
    paths
}

/// One machine as the scripts create it.
#[derive(Debug, Default, Clone)]
struct Machine {
    platform: String,
    uid: BTreeMap<u32, u32>,
}

impl Machine {
    fn uid_bytes(&self) -> Option<[u8; 12]> {
        let mut bytes = [0u8; 12];
        for (k, offset) in [0x7E8u32, 0x7EC, 0x7F0].iter().enumerate() {
            bytes[4 * k..4 * k + 4].copy_from_slice(&self.uid.get(offset)?.to_le_bytes());
        }
        Some(bytes)
    }
}

/// Runs a script the way the Monitor reads it, as far as files, machines and peripherals go:
/// follows `include $ORIGIN/...`, records each machine's platform and unique ID, and checks
/// every `$ORIGIN` path and every peripheral path against the current machine's platform.
fn run_script(file: &str, machines: &mut BTreeMap<String, Machine>, current: &mut Option<String>) {
    let path = renode().join(file);
    let text = read(&path);
    let manifest = read(&root().join("firmware/Cargo.toml"));
    for line in code_lines(&text, "#") {
        let words: Vec<&str> = line.split_whitespace().collect();
        for rel in words.iter().filter_map(|w| w.split_once("$ORIGIN/").map(|(_, rel)| rel.trim_matches('"'))) {
            if let Some(bin) = rel.strip_prefix("../firmware/target/thumbv7m-none-eabi/release/") {
                assert!(manifest.contains(&format!("name = \"{bin}\"")), "{file}: {bin} is no firmware binary");
            } else {
                assert!(renode().join(rel).is_file(), "{file}: renode/{rel} is missing");
            }
        }
        match words.as_slice() {
            ["include", target] if target.starts_with("$ORIGIN/") && target.ends_with(".resc") => {
                run_script(&target["$ORIGIN/".len()..], machines, current);
            }
            ["mach", "create", name] | ["mach", "set", name] => {
                let name = name.trim_matches('"').to_string();
                if words[1] == "create" {
                    assert!(!machines.contains_key(&name), "{file}: machine {name} created twice");
                    machines.insert(name.clone(), Machine::default());
                }
                assert!(machines.contains_key(&name), "{file}: mach set {name} before it is created");
                *current = Some(name);
            }
            ["machine", "LoadPlatformDescription", repl] => {
                let name = current.clone().unwrap_or_else(|| panic!("{file}: a platform with no machine"));
                machines.get_mut(&name).unwrap().platform = repl.trim_start_matches("$ORIGIN/").to_string();
            }
            ["sysbus.systemMemory", "WriteDoubleWord", offset, value] => {
                let name = current.clone().unwrap();
                let parse = |s: &str| u32::from_str_radix(s.trim_start_matches("0x"), 16).unwrap();
                machines.get_mut(&name).unwrap().uid.insert(parse(offset), parse(value));
            }
            _ => {}
        }
        for p in peripheral_paths(line) {
            let name = current.clone().unwrap_or_else(|| panic!("{file}: {p} with no machine"));
            let repl = &machines[&name].platform;
            assert!(resolves(&platform(repl), &p), "{file}: {p} is not a peripheral of {repl} ({name})");
        }
    }
}

/// Every machine of every device script.
fn all_scripts() -> BTreeMap<String, BTreeMap<String, Machine>> {
    let mut scripts = BTreeMap::new();
    for entry in std::fs::read_dir(renode()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "resc") {
            let file = path.file_name().unwrap().to_str().unwrap().to_string();
            let mut machines = BTreeMap::new();
            run_script(&file, &mut machines, &mut None);
            scripts.insert(file, machines);
        }
    }
    scripts
}

#[test]
fn scripts_name_existing_files_binaries_and_peripherals() {
    let scripts = all_scripts();
    for name in ["bench.resc", "bus.resc", "sgh10.resc", "sgh50.resc", "wv5800m.resc"] {
        assert!(scripts.contains_key(name), "renode/{name}");
    }
    for (file, machines) in &scripts {
        assert!(!machines.is_empty(), "{file} creates no machine");
        for (name, m) in machines {
            assert!(renode().join(&m.platform).is_file(), "{file}: {name} loads no platform");
        }
    }
    // The platforms no script uses yet load what they build on, too.
    for repl in ["ap10t.repl", "wv58mr.repl"] {
        assert!(platform(repl).contains_key("can1"), "{repl}");
    }
}

/// Every machine has its own 96-bit unique ID (the stock platform had none, so every blank
/// board derived serial number 7BD5C66Fh, the CRC-32 of 12 zero bytes).
#[test]
fn every_machine_has_a_unique_id_of_its_own() {
    assert_eq!(crc32(&[0u8; 12]), 0x7BD5_C66F, "the serial number every board had");
    for (file, machines) in all_scripts() {
        let mut seen = BTreeSet::new();
        for (name, m) in &machines {
            let uid = m.uid_bytes().unwrap_or_else(|| panic!("{file}: machine {name} has no unique ID"));
            assert!(seen.insert(uid), "{file}: machine {name} shares its unique ID");
        }
    }
    let stm = read(&renode().join("stm32f103cb.repl"));
    assert!(stm.contains("systemMemory: Memory.MappedMemory @ sysbus 0x1FFFF000"), "the system memory page");
}

/// The serial numbers the Robot tests expect are the CRC-32 of the IDs the scripts give
/// (docs/decisions.md D-FW-3, `board_plan::straps::serial_from_uid`).
#[test]
fn robot_serial_numbers_follow_from_the_unique_ids() {
    let scripts = all_scripts();
    let robot = read(&renode().join("tests/canopen.robot"));
    let expected = |var: &str| -> u32 {
        let line = robot.lines().find(|l| l.starts_with(&format!("${{{var}}}"))).unwrap_or_else(|| panic!("{var}"));
        u32::from_str_radix(line.split_whitespace().nth(1).unwrap(), 16).unwrap()
    };
    for (machine, var) in [("sgh50a", "SGH50A_SERIAL"), ("sgh50b", "SGH50B_SERIAL")] {
        let uid = scripts["sgh50.resc"][machine].uid_bytes().unwrap();
        assert_eq!(crc32(&uid), expected(var), "{machine}");
    }
}

/// The platform loads without a network: no file names an address on the internet outside
/// comments, and the stock platform's sysbus init (ApplySVD of a downloaded file) is replaced,
/// not extended.
#[test]
fn nothing_is_fetched_from_the_network() {
    for entry in std::fs::read_dir(renode()).unwrap().chain(std::fs::read_dir(renode().join("tests")).unwrap()) {
        let path = entry.unwrap().path();
        let comment = match path.extension().and_then(|e| e.to_str()) {
            Some("repl") => "//",
            Some("resc") | Some("robot") | Some("py") => "#",
            _ => continue,
        };
        let text = read(&path);
        for line in code_lines(&text, comment) {
            assert!(!line.contains("http"), "{}: {line}", path.display());
            assert!(!line.contains("ApplySVD"), "{}: {line}", path.display());
        }
    }
    let stm = read(&renode().join("stm32f103cb.repl"));
    let init = stm.find("\nsysbus:\n    init:\n").expect("stm32f103cb.repl replaces the stock sysbus init");
    assert!(!stm[init..].starts_with("\nsysbus:\n    init add:"));
}

/// What the Robot tests name: the scripts and command files they include, the binaries, and the
/// peripherals of the machines they address.
#[test]
fn robot_tests_name_existing_files_and_peripherals() {
    let scripts = all_scripts();
    let machines: BTreeMap<_, _> =
        scripts.values().flat_map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone()))).collect();
    let manifest = read(&root().join("firmware/Cargo.toml"));
    let robot = read(&renode().join("tests/canopen.robot"));
    let mut includes = 0;
    for line in robot.lines().filter(|l| !l.trim_start().starts_with('#')) {
        if let Some((_, rel)) = line.split_once("${FILES}/") {
            let rel = rel.split_whitespace().next().unwrap();
            assert!(renode().join(rel).is_file(), "canopen.robot: renode/{rel} is missing");
            includes += 1;
        }
        if let Some((_, bin)) = line.split_once("${FIRMWARE}/") {
            let bin = bin.split_whitespace().next().unwrap();
            assert!(manifest.contains(&format!("name = \"{bin}\"")), "canopen.robot: {bin} is no firmware binary");
        }
        let paths = peripheral_paths(line);
        if !paths.is_empty() {
            let machine = line.split_once("machine=").map(|(_, m)| m.split_whitespace().next().unwrap());
            let machine = machine.unwrap_or_else(|| panic!("canopen.robot: {line}: which machine?"));
            for p in paths {
                assert!(resolves(&platform(&machines[machine].platform), &p), "canopen.robot: {p} on {machine}");
            }
        }
        // The machines sensor_feed addresses have the sensor stand-in canopen.py feeds.
        if let Some((_, m)) = line.split_once("Feed Sensor") {
            let m = m.split_whitespace().next().unwrap_or("$");
            if !m.starts_with('$') {
                assert!(resolves(&platform(&machines[m].platform), "sysbus.spi1.sensor"), "{m} has no sensor");
            }
        }
    }
    assert!(includes >= 5, "canopen.py, the device scripts, the bench and the bus");
    let py = read(&renode().join("canopen.py"));
    assert!(py.contains("machine[\"sysbus.spi1.sensor\"]"), "canopen.py feeds spi1's sensor");
}
