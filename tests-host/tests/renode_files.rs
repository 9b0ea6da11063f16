//! The Renode bench (`renode/`) cannot run here, so this keeps what can be checked without
//! Renode true of its files: every file a script, platform or Robot test names exists, every
//! firmware binary it names is one `cargo firmware` builds, every peripheral a script or test
//! addresses (`sysbus.spi1.sensor`) is declared in the platform its machine loads, nothing is
//! fetched from the network, every machine has a unique ID of its own, the serial numbers
//! the Robot tests expect are the ones those IDs give, every keyword (and named argument) the
//! Robot tests call is one Renode's Robot framework provides or the file defines, and the frames
//! the tests wait for are frames the od-core nodes send: every test's steps are replayed on the
//! virtual bus with the machines the scripts create (their images, straps, unique IDs and
//! sensor feeds).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use board_plan::sensor::{multiturn_raw, wire_raw_um, Reading};
use board_plan::straps::Straps;
use od_core::devices::wv5800m::{self, Turns};
use od_core::devices::wv58mr::{table_of, Wv58mr};
use od_core::devices::{sgh10, sgh50};
use od_core::encoder::{program_serial, Encoder, SensorFault};
use od_core::j1939::node::J1939Node;
use od_core::node::{CanopenDevice, Node};
use od_core::storage::crc::crc32;
use od_core::storage::{identity, Loaded, ParamFlash, Record};
use od_core::{Bitrate, CanId, Frame, Instant};
use tests_host::ap10t::Display;
use tests_host::bus::Bus;
use tests_host::encoder::{Sensed, Sensor};
use tests_host::flash::RamFlash;
use tests_host::j1939::SensedJ1939;
use tests_host::sim::devices::REGION;

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
    /// The firmware binary its reset macro loads (`$global.<bin>_bin`).
    bin: String,
    /// The CAN hub its bxCAN is connected to.
    hub: String,
    /// The parameter image loaded at 0x0801F000, if any (a path below renode/).
    image: Option<String>,
    /// The strap pins PB12..PB15 as its reset macro drives them (bit k = PB(12+k) high = open).
    straps: u8,
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
            ["sysbus", "LoadELF", bin] => {
                let name = current.clone().unwrap();
                let bin = bin.strip_prefix("$global.").and_then(|b| b.strip_suffix("_bin"));
                machines.get_mut(&name).unwrap().bin = bin.unwrap_or_else(|| panic!("{file}: LoadELF {line}")).into();
            }
            ["sysbus", "LoadBinary", image, "0x0801F000"] => {
                let name = current.clone().unwrap();
                machines.get_mut(&name).unwrap().image = Some(image.trim_start_matches("$ORIGIN/").to_string());
            }
            ["sysbus.gpioPortB", "OnGPIO", pin, level] => {
                let name = current.clone().unwrap();
                let bit = 1u8 << (pin.parse::<u8>().unwrap() - 12);
                let m = machines.get_mut(&name).unwrap();
                m.straps = if *level == "true" { m.straps | bit } else { m.straps & !bit };
            }
            ["connector", "Connect", "sysbus.can1", hub] => {
                let name = current.clone().unwrap();
                machines.get_mut(&name).unwrap().hub = hub.trim_matches('"').to_string();
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
    for name in ["bench.resc", "bus.resc", "sgh10.resc", "sgh50.resc", "wv5800m.resc", "ap10t.resc", "wv58mr.resc"] {
        assert!(scripts.contains_key(name), "renode/{name}");
    }
    for (file, machines) in &scripts {
        assert!(!machines.is_empty(), "{file} creates no machine");
        for (name, m) in machines {
            assert!(renode().join(&m.platform).is_file(), "{file}: {name} loads no platform");
            assert!(!m.bin.is_empty(), "{file}: {name} loads no firmware");
            assert!(!m.hub.is_empty(), "{file}: {name} is on no CAN hub");
            if let Some(image) = &m.image {
                assert!(renode().join(image).is_file(), "{file}: {name} loads {image}, which is missing");
            }
        }
    }
    // All five devices on the bench and on the one-bus bench; the J1939 pair on a hub of its
    // own (J1939 and CANopen are two buses), every CANopen device of bus.resc on one.
    for file in ["bench.resc", "bus.resc"] {
        let bins: BTreeSet<_> = scripts[file].values().map(|m| m.bin.as_str()).collect();
        assert_eq!(bins, BTreeSet::from(["ap10t", "sgh10", "sgh50", "wv5800m", "wv58mr"]), "{file}");
        for m in scripts[file].values() {
            let j1939_hub = scripts[file].values().filter(|o| o.hub == m.hub).all(|o| o.bin == "wv58mr");
            assert_eq!(m.bin == "wv58mr", j1939_hub, "{file}: {} shares the hub {} across protocols", m.bin, m.hub);
        }
    }
    let can0: BTreeSet<_> = scripts["bus.resc"].values().filter(|m| m.hub == "can0").map(|m| m.bin.as_str()).collect();
    assert_eq!(can0, BTreeSet::from(["ap10t", "sgh10", "sgh50", "wv5800m"]));
    // Each machine loads the platform of its board.
    for machines in scripts.values() {
        for m in machines.values() {
            assert_eq!(m.platform, format!("{}.repl", m.bin), "{} runs on its own board", m.bin);
        }
    }
}

/// Every script that creates machines sets the 1 ms quantum renode/README.md ("Speed",
/// docs/decisions.md D-RN-3) describes, and no script or test sets another one; scripts whose
/// machines share a hub execute them serially. (ap10t.resc was left at 10 µs, the quantum that
/// made the first bench crawl, when the others moved to 1 ms.)
#[test]
fn every_script_sets_the_one_millisecond_quantum() {
    let scripts = all_scripts();
    for entry in std::fs::read_dir(renode()).unwrap().chain(std::fs::read_dir(renode().join("tests")).unwrap()) {
        let path = entry.unwrap().path();
        let Some(ext) = path.extension().and_then(|e| e.to_str()) else { continue };
        if ext != "resc" && ext != "robot" {
            continue;
        }
        let text = read(&path);
        let file = path.file_name().unwrap().to_str().unwrap();
        let quanta: Vec<_> = code_lines(&text, "#").filter(|l| l.contains("SetGlobalQuantum")).collect();
        for q in &quanta {
            assert!(q.trim_end().ends_with("SetGlobalQuantum \"0.001\""), "{file}: {q}");
        }
        if ext == "resc" {
            assert!(!quanta.is_empty(), "{file} sets no quantum");
            let machines = &scripts[file];
            let shared = machines.values().any(|m| machines.values().filter(|o| o.hub == m.hub).count() > 1);
            if shared {
                assert!(text.contains("emulation SetGlobalSerialExecution True"), "{file}: serial execution");
            }
        }
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
    let robot = read(&renode().join("tests/bench.robot"));
    let vars = robot_variables(&robot);
    let expected = |var: &str| -> u32 { u32::from_str_radix(&vars[var], 16).unwrap() };
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
    let mut includes = 0;
    let robots = robot_files();
    assert!(!robots.is_empty(), "renode/tests/*.robot");
    for (file, robot) in &robots {
        for line in robot.lines().filter(|l| !l.trim_start().starts_with('#')) {
            if let Some((_, rel)) = line.split_once("${FILES}/") {
                let rel = rel.split_whitespace().next().unwrap();
                assert!(renode().join(rel).is_file(), "{file}: renode/{rel} is missing");
                includes += 1;
            }
            if let Some((_, bin)) = line.split_once("${FIRMWARE}/") {
                let bin = bin.split_whitespace().next().unwrap();
                assert!(manifest.contains(&format!("name = \"{bin}\"")), "{file}: {bin} is no firmware binary");
            }
            let paths = peripheral_paths(line);
            if !paths.is_empty() {
                let machine = line.split_once("machine=").map(|(_, m)| m.split_whitespace().next().unwrap());
                let machine = machine.unwrap_or_else(|| panic!("{file}: {line}: which machine?"));
                for p in paths {
                    assert!(resolves(&platform(&machines[machine].platform), &p), "{file}: {p} on {machine}");
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
    }
    assert!(includes >= 7, "canopen.py, the device scripts, the bench and the bus");
    let py = read(&renode().join("canopen.py"));
    assert!(py.contains("machine[\"sysbus.spi1.sensor\"]"), "canopen.py feeds spi1's sensor");
}

/// The Robot files of renode/tests: (file name, text).
fn robot_files() -> Vec<(String, String)> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(renode().join("tests")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "robot") {
            files.push((path.file_name().unwrap().to_str().unwrap().to_string(), read(&path)));
        }
    }
    files.sort();
    files
}

/// The cells of a Robot line (separated by two or more spaces), without a trailing comment.
fn cells(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    for cell in line.split("  ").map(str::trim).filter(|c| !c.is_empty()) {
        if cell.starts_with('#') {
            break;
        }
        out.push(cell.to_string());
    }
    out
}

/// The lines of one section (`*** Name ***`) of a Robot file.
fn section<'a>(text: &'a str, name: &str) -> Vec<&'a str> {
    let mut inside = false;
    let mut lines = Vec::new();
    for line in text.lines() {
        if let Some(header) = line.strip_prefix("***") {
            inside = header.trim_end_matches('*').trim().eq_ignore_ascii_case(name);
            continue;
        }
        if inside {
            lines.push(line);
        }
    }
    lines
}

/// The `*** Variables ***` of a Robot file: name (without `${}`) to value.
fn robot_variables(text: &str) -> BTreeMap<String, String> {
    let mut vars = BTreeMap::new();
    for line in section(text, "Variables") {
        let c = cells(line);
        if let Some(name) = c.first().and_then(|n| n.strip_prefix("${")).and_then(|n| n.strip_suffix('}')) {
            vars.insert(name.to_string(), c.get(1).cloned().unwrap_or_default());
        }
    }
    vars
}

/// The blocks (test cases or keywords) of a section: name and the cells of each step.
fn blocks(text: &str, name: &str) -> Vec<(String, Vec<Vec<String>>)> {
    let mut out: Vec<(String, Vec<Vec<String>>)> = Vec::new();
    for line in section(text, name) {
        if line.trim().is_empty() || line.trim_start().starts_with('#') {
            continue;
        }
        if !line.starts_with(' ') {
            out.push((line.trim().to_string(), Vec::new()));
            continue;
        }
        let c = cells(line);
        if c.is_empty() {
            continue;
        }
        let block = out.last_mut().unwrap_or_else(|| panic!("a step outside a block: {line}"));
        if c[0] == "..." {
            block.1.last_mut().expect("a continuation of nothing").extend(c[1..].iter().cloned());
        } else {
            block.1.push(c);
        }
    }
    out
}

/// A keyword name as Robot Framework matches it: case, spaces and underscores do not count.
fn normalized(name: &str) -> String {
    name.chars().filter(|c| *c != ' ' && *c != '_').flat_map(char::to_lowercase).collect()
}

/// The keywords of Renode's Robot framework the tests may call, with the names of their
/// arguments (renode 06854d4d: src/Renode/RobotFrameworkEngine/RenodeKeywords.cs,
/// CANKeywords.cs, LedKeywords.cs; tests/renode-keywords.robot for Reset Emulation's test setup).
const RENODE_KEYWORDS: &[(&str, &[&str])] = &[
    ("Reset Emulation", &[]),
    ("Start Emulation", &[]),
    ("Execute Command", &["command", "machine"]),
    ("Execute Python", &["command", "machine"]),
    ("Execute Script", &["path"]),
    ("Wait For Pause", &["timeout"]),
    ("Register Failing Log String", &["pattern", "treatAsRegex"]),
    ("Create Log Tester", &["timeout", "defaultPauseEmulation", "maxLogEntries"]),
    (
        "Wait For Log Entry",
        &["pattern", "timeout", "keep", "treatAsRegex", "pauseEmulation", "level", "startEmulation"],
    ),
    ("Should Not Be In Log", &["pattern", "timeout", "treatAsRegex", "pauseEmulation", "level"]),
    ("Clear Log Tester History", &[]),
    ("Create CAN Tester", &["canHub", "defaultTimeout", "machine"]),
    ("Wait For Frame With Id", &["id", "timeout", "testerId", "pauseEmulation"]),
    ("Set Default CAN Timeout", &["timeout"]),
    ("Create LED Tester", &["led", "defaultTimeout", "machine"]),
    ("Set Default LED Timeout", &["timeout"]),
    ("Assert LED State", &["state", "timeout", "testerId", "pauseEmulation"]),
    ("Assert And Hold LED State", &["initialState", "timeoutAssert", "timeoutHold", "testerId", "pauseEmulation"]),
    ("Assert LED Duty Cycle", &["testDuration", "expectedDutyCycle", "tolerance", "testerId", "pauseEmulation"]),
    (
        "Assert LED Is Blinking",
        &["testDuration", "onDuration", "offDuration", "tolerance", "testerId", "pauseEmulation"],
    ),
];

/// Every step of every test and keyword calls a keyword Renode provides (with argument names it
/// takes) or one the file defines (with the arguments it declares).
#[test]
fn robot_tests_call_only_keywords_renode_provides() {
    for (file, robot) in robot_files() {
        let mut known: BTreeMap<String, Vec<String>> = RENODE_KEYWORDS
            .iter()
            .map(|(k, args)| (normalized(k), args.iter().map(|a| a.to_string()).collect()))
            .collect();
        let keywords = blocks(&robot, "Keywords");
        for (name, steps) in &keywords {
            let args = steps
                .iter()
                .find(|c| c[0] == "[Arguments]")
                .map(|c| {
                    c[1..]
                        .iter()
                        .map(|a| a.trim_start_matches("${").split(['}', '=']).next().unwrap().to_string())
                        .collect()
                })
                .unwrap_or_default();
            assert!(known.insert(normalized(name), args).is_none(), "{file}: {name} defined twice or shadows Renode's");
        }
        let cases = blocks(&robot, "Test Cases");
        assert!(!cases.is_empty(), "{file} has no test");
        for (block, steps) in keywords.iter().chain(&cases) {
            for c in steps {
                if c[0].starts_with('[') {
                    continue;
                }
                // `${x}=    Keyword    ...`
                let k = usize::from(c[0].starts_with("${") && c[0].ends_with('='));
                let name = &c[k];
                let args = known.get(&normalized(name)).unwrap_or_else(|| panic!("{file}: {block}: no keyword {name}"));
                for arg in &c[k + 1..] {
                    if let Some((key, _)) = arg.split_once('=') {
                        if key.chars().all(|ch| ch.is_ascii_alphanumeric()) && !key.is_empty() {
                            assert!(args.contains(&key.to_string()), "{file}: {block}: {name} takes no argument {key}");
                        }
                    }
                }
            }
        }
    }
}

/// A Robot step with the file's variables and a keyword's arguments put in.
fn expand(cell: &str, vars: &BTreeMap<String, String>) -> String {
    let mut out = cell.to_string();
    // Values may name other variables (${TIMEOUT} in an argument default): a few rounds.
    for _ in 0..4 {
        for (k, v) in vars {
            out = out.replace(&format!("${{{k}}}"), v);
        }
    }
    out
}

/// The Renode-level steps of a test case: user keywords inlined with their arguments.
fn primitive_steps(
    steps: &[Vec<String>],
    keywords: &BTreeMap<String, Vec<Vec<String>>>,
    vars: &BTreeMap<String, String>,
    out: &mut Vec<Vec<String>>,
) {
    for c in steps {
        if c[0].starts_with('[') {
            continue;
        }
        let k = usize::from(c[0].starts_with("${") && c[0].ends_with('='));
        let c: Vec<String> = c[k..].iter().map(|x| expand(x, vars)).collect();
        let Some(body) = keywords.get(&normalized(&c[0])) else {
            out.push(c);
            continue;
        };
        let mut local = vars.clone();
        let declared = body.iter().find(|s| s[0] == "[Arguments]").map(|s| s[1..].to_vec()).unwrap_or_default();
        let (mut positional, mut named) = (Vec::new(), BTreeMap::new());
        for a in &c[1..] {
            match a.split_once('=') {
                Some((key, v)) if declared.iter().any(|d| d.starts_with(&format!("${{{key}}}"))) => {
                    named.insert(key.to_string(), v.to_string());
                }
                _ => positional.push(a.clone()),
            }
        }
        for (i, d) in declared.iter().enumerate() {
            let (name, default) = match d.split_once("}=") {
                Some((n, def)) => (n.trim_start_matches("${").to_string(), Some(expand(def, vars))),
                None => (d.trim_start_matches("${").trim_end_matches('}').to_string(), None),
            };
            let value = named.get(&name).cloned().or_else(|| positional.get(i).cloned()).or(default);
            let value = value.unwrap_or_else(|| panic!("{}: no value for {name}", c[0]));
            local.insert(name, value.replace("${EMPTY}", ""));
        }
        primitive_steps(body, keywords, &local, out);
    }
}

/// A Monitor command's words; a quoted string is one word (without its quotes).
fn monitor_words(command: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut rest = command.trim();
    while !rest.is_empty() {
        if let Some(quoted) = rest.strip_prefix('"') {
            let end = quoted.find('"').expect("an unterminated string");
            words.push(quoted[..end].to_string());
            rest = quoted[end + 1..].trim_start();
        } else {
            let end = rest.find(' ').unwrap_or(rest.len());
            words.push(rest[..end].to_string());
            rest = rest[end..].trim_start();
        }
    }
    words
}

/// A frame as `can_trace` writes it (renode/canopen.py, format_frame): identifier in 3 or 8
/// hex digits, [length], the data bytes.
fn trace(frame: &Frame) -> String {
    let id = match frame.id {
        CanId::Std(id) => format!("{id:03X}"),
        CanId::Ext(id) => format!("{id:08X}"),
    };
    let mut text = format!("{id} [{}]", frame.payload().len());
    for b in frame.payload() {
        text += &format!(" {b:02X}");
    }
    text
}

fn number(text: &str) -> u32 {
    match text.strip_prefix("0x") {
        Some(hex) => u32::from_str_radix(hex, 16).unwrap(),
        None => text.parse().unwrap(),
    }
}

fn hex_bytes(text: &str) -> Vec<u8> {
    let digits: String = text.split_whitespace().collect();
    (0..digits.len()).step_by(2).map(|i| u8::from_str_radix(&digits[i..i + 2], 16).unwrap()).collect()
}

/// The named argument `key=` of a step, if given.
fn named_arg<'a>(c: &'a [String], key: &str) -> Option<&'a str> {
    c.iter().find_map(|a| a.strip_prefix(key).and_then(|v| v.strip_prefix('=')))
}

/// How an encoder turns a sensor frame's reading into its raw count.
type RawOf = fn(Reading) -> u32;

/// One hub of a Robot test replayed on the virtual bus: the machines the scripts put on it.
struct Hub {
    bus: Bus,
    /// The AP10T's station number, if one is on the hub.
    ap10t: Option<usize>,
    /// The bit rate of every other node (they boot with one rate; `None`: the AP10T is alone).
    rate: Option<Bitrate>,
    /// Each machine's station number.
    stations: BTreeMap<String, usize>,
    /// Each encoder's sensor, with the raw count a fed sensor frame gives it.
    sensors: BTreeMap<String, (Sensor, RawOf)>,
    /// What `can_trace` has logged since the last Clear Log Tester History.
    log: Vec<String>,
}

/// The raw count a fed sensor frame gives an SGH10: its drum pays out 100 mm of wire per turn
/// (boards/stm32f103 `sgh10::DRUM_UM_PER_TURN`).
fn sgh10_raw(r: Reading) -> u32 {
    wire_raw_um(r, 100_000)
}

/// The same for the SGH50: 250 mm per turn (`sgh50::DRUM_UM_PER_TURN`).
fn sgh50_raw(r: Reading) -> u32 {
    wire_raw_um(r, 250_000)
}

/// The same for the rotary encoders of the bench: 12-bit multiturn.
fn rotary_raw(r: Reading) -> u32 {
    multiturn_raw(r, 12)
}

/// A CANopen encoder station as the firmware boots it (`firmware::run::boot`: a flash without a
/// serial number gets the unique ID's, D-FW-3), sampling `sensor`.
fn canopen_encoder<E: Encoder + CanopenDevice + Clone + 'static>(
    bus: &mut Bus,
    flash: RamFlash,
    device: E,
    serial: u32,
    sensor: &Sensor,
) -> usize {
    let mut params = ParamFlash::new(flash, REGION, identity(device.table()));
    // The bus runs at the rate the node boots with, so that its boot-up is heard.
    let rate = Node::boot(device.clone(), &params.load()).context().bitrate;
    bus.set_bitrate(rate);
    let s = sensor.clone();
    bus.add_with_flash(params, move |loaded| {
        let mut node = Node::boot(device.clone(), loaded);
        if loaded.image().is_none_or(|i| i.get(0x1018, 4).is_none()) {
            program_serial(&mut node.split().1.od, serial);
        }
        Sensed::new(node, s.clone())
    })
}

/// Builds the virtual bus of `hub` with every machine on it, each booted as its firmware boots
/// it: from its parameter image or a blank flash, its straps, its unique ID's serial number.
/// Renode models no bit timing, so every node hears every frame; the virtual bus models rates,
/// so the replay runs it at the nodes' common rate (see [`Hub::send`] for the AP10T).
fn virtual_hub(machines: &BTreeMap<String, Machine>, hub: &str) -> Hub {
    let mut out = Hub {
        bus: Bus::new(),
        ap10t: None,
        rate: None,
        stations: BTreeMap::new(),
        sensors: BTreeMap::new(),
        log: Vec::new(),
    };
    // J1939 at its 250 kbit/s; a CANopen node runs at the rate it boots with.
    out.bus.set_bitrate(Bitrate::K250);
    for (name, m) in machines.iter().filter(|(_, m)| m.hub == hub) {
        let flash = match &m.image {
            Some(image) => RamFlash::from_bytes(std::fs::read(renode().join(image)).unwrap()),
            None => RamFlash::new(REGION.pages as usize),
        };
        let serial = crc32(&m.uid_bytes().unwrap());
        let straps = Straps(m.straps);
        // DummySPISlave answers 00h until sensor_feed queues frames: no sensor.
        let sensor = Sensor::new(0);
        sensor.fail(SensorFault::NoResponse);
        let (n, raw): (usize, RawOf) = match m.bin.as_str() {
            "ap10t" => {
                let params = ParamFlash::new(flash, REGION, identity(od_core::devices::ap10t::table::TABLE));
                let n = out.bus.add_with_flash(params, Display::boot);
                out.ap10t = Some(n);
                out.stations.insert(name.clone(), n);
                continue;
            }
            "sgh10" => {
                let device = sgh10::Sgh10::new(straps.sgh10());
                (canopen_encoder(&mut out.bus, flash, device, serial, &sensor), sgh10_raw)
            }
            "sgh50" => {
                let device = sgh50::Sgh50::new(straps.sgh50());
                (canopen_encoder(&mut out.bus, flash, device, serial, &sensor), sgh50_raw)
            }
            "wv5800m" => {
                // The default image: the WV5800M, 12-bit multiturn (D-FW-2).
                let variant = wv5800m::Variant { model: wv5800m::Model::Wv, turns: Turns::Multi12 };
                let device = wv5800m::Wv5800m::new(variant);
                (canopen_encoder(&mut out.bus, flash, device, serial, &sensor), rotary_raw)
            }
            "wv58mr" => {
                let table = table_of(Turns::Multi12);
                let params = ParamFlash::new(flash, REGION, identity(table));
                let s = sensor.clone();
                let n = out.bus.add_with_flash(params, move |loaded| {
                    // firmware::run::boot_j1939: a flash without a serial number gets the unique
                    // ID's, in the image the NAME is built from.
                    let has_serial = loaded.image().is_some_and(|i| i.get(0x1018, 4).is_some());
                    let loaded = if has_serial {
                        loaded.clone()
                    } else {
                        let mut image = loaded.image().cloned().unwrap_or_default();
                        for e in
                            table.iter().filter(|e| (e.index, e.sub) == (0x1018, 4) || (e.index, e.sub) == (0x650B, 0))
                        {
                            image.set(Record::of(e, serial)).unwrap();
                        }
                        Loaded::Image(image)
                    };
                    SensedJ1939::new(J1939Node::boot(Wv58mr::new(Turns::Multi12), &loaded), s.clone())
                });
                (n, rotary_raw)
            }
            other => panic!("{name}: no virtual station for {other}"),
        };
        out.stations.insert(name.clone(), n);
        out.sensors.insert(name.clone(), (sensor, raw));
        let rate = out.bus.node_bitrate(n);
        assert!(out.rate.is_none_or(|r| r == rate), "{hub}: nodes boot at different rates");
        out.rate = Some(rate);
    }
    if let Some(rate) = out.rate {
        out.bus.set_bitrate(rate);
    }
    out
}

impl Hub {
    fn run_to(&mut self, t: Instant) {
        self.bus.advance_to(t);
        self.log.extend(self.bus.drain().iter().map(|s| trace(&s.frame)));
    }

    /// Sends `frame` at `now` as a master on the hub; returns the time it went out. In Renode an
    /// AP10T detecting the rate takes the first frame at whatever rate it listens: alone on the
    /// hub it gets the frame at that rate; with other nodes the replay sends once it listens at
    /// theirs (so that it runs at their rate, as it would on a real bus; on the virtual bus
    /// nodes at different rates would not hear each other), at most one round (5 s) later.
    fn send(&mut self, frame: Frame, mut now: Instant) -> Instant {
        if let Some(n) = self.ap10t {
            match self.rate {
                None => {
                    let rate = self.bus.node_bitrate(n);
                    self.bus.set_bitrate(rate);
                }
                Some(rate) => {
                    let latest = now.add_millis(6000);
                    while self.bus.node_bitrate(n) != rate {
                        assert!(now < latest, "the AP10T never listens at {rate:?}");
                        now = now.add_millis(1);
                        self.run_to(now);
                    }
                }
            }
        }
        self.log.push(trace(&frame));
        self.bus.send(frame);
        self.log.extend(self.bus.drain().iter().map(|s| trace(&s.frame)));
        now
    }
}

/// Replays every Robot test on the virtual bus, one bus per hub with the machines the scripts
/// put there: Wait For Log Entry on a `can_trace` line (and Wait For Frame With Id on a CAN
/// tester's hub) waits, in 1 ms steps up to its timeout, for such a frame; Should Not Be In Log
/// on one checks that none came within its timeout; `can_send`/`can_send_ext` send,
/// `sensor_feed` gives the sensor its reading, `machine Reset` power-cycles the machine (its
/// flash kept), `RunFor`, the LED assertions and the watchdog test's minute let time pass. A
/// hub on which `lss_fastscan` runs is left from then on (the LSS sequence is
/// `renode_lss.rs`'s and the Python master's). A test waiting for a frame the od-core nodes do
/// not send fails here as it would in Renode.
#[test]
fn robot_frames_are_the_nodes_frames_on_the_virtual_bus() {
    let mut replayed = 0;
    for (file, robot) in robot_files() {
        let vars = robot_variables(&robot);
        let keywords: BTreeMap<_, _> =
            blocks(&robot, "Keywords").into_iter().map(|(k, s)| (normalized(&k), s)).collect();
        for (case, steps) in blocks(&robot, "Test Cases") {
            let mut prims = Vec::new();
            primitive_steps(&steps, &keywords, &vars, &mut prims);
            let mut machines = BTreeMap::new();
            let mut hubs: BTreeMap<String, Hub> = BTreeMap::new();
            let mut now = Instant::ZERO;
            let mut current: Option<String> = None;
            let mut tester: Option<String> = None;
            let timeout_ms = |c: &[String]| -> u64 {
                let t = named_arg(c, "timeout").unwrap_or(vars["TIMEOUT"].as_str());
                (t.parse::<f64>().unwrap() * 1000.0) as u64
            };
            for c in &prims {
                let what = format!("{file}: {case}: {}", c.join("  "));
                match c[0].as_str() {
                    "Execute Command" => {
                        let w = monitor_words(&c[1]);
                        match w.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
                            ["include", path] if path.ends_with(".resc") => {
                                let rel = path.rsplit_once("/").unwrap().1;
                                let before: BTreeSet<String> = machines.keys().cloned().collect();
                                run_script(rel, &mut machines, &mut None);
                                let new_hubs: BTreeSet<String> = machines
                                    .iter()
                                    .filter(|(k, _)| !before.contains(*k))
                                    .map(|(_, m)| m.hub.clone())
                                    .collect();
                                for h in new_hubs {
                                    hubs.insert(h.clone(), virtual_hub(&machines, &h));
                                }
                            }
                            ["can_send" | "can_send_ext", hub, id, data] => {
                                if let Some(h) = hubs.get_mut(*hub) {
                                    let id = number(id);
                                    let id = if w[0] == "can_send" { CanId::Std(id as u16) } else { CanId::Ext(id) };
                                    now = h.send(Frame::new(id, &hex_bytes(data)), now);
                                    hubs.values_mut().for_each(|h| h.run_to(now));
                                }
                            }
                            ["sensor_feed", machine, turns, angle, _] => {
                                for h in hubs.values_mut() {
                                    if let Some((s, raw)) = h.sensors.get(*machine) {
                                        let r = Reading {
                                            turns: number(turns) as u16,
                                            angle: number(angle) as u16,
                                            warning: false,
                                        };
                                        s.set(raw(r));
                                        s.heal();
                                    }
                                }
                            }
                            ["mach", "set", machine] => current = Some(machine.to_string()),
                            ["machine", "Reset"] => {
                                let m = current.clone().expect("machine Reset with no machine set");
                                let h = hubs
                                    .values_mut()
                                    .find(|h| h.stations.contains_key(&m))
                                    .expect("a machine on a hub");
                                let n = h.stations[&m];
                                h.bus.power_cycle(n);
                                h.log.extend(h.bus.drain().iter().map(|s| trace(&s.frame)));
                            }
                            ["lss_fastscan", hub, ..] => {
                                hubs.remove(*hub);
                            }
                            ["emulation", "RunFor", t] => {
                                now = now.add_millis((t.parse::<f64>().unwrap() * 1000.0) as u64);
                                hubs.values_mut().for_each(|h| h.run_to(now));
                            }
                            _ => {}
                        }
                    }
                    "Wait For Log Entry" | "Should Not Be In Log" => {
                        let pattern = &c[1];
                        // "CAN <hub> <frame>", or "CAN <hub>" for any frame on the hub.
                        let on_hub = pattern.strip_prefix("CAN ").map(|p| p.split_once(' ').unwrap_or((p, "")));
                        let end = now.add_millis(timeout_ms(c));
                        match on_hub {
                            Some((hub, frame)) if hubs.contains_key(hub) => {
                                let h = hubs.get_mut(hub).unwrap();
                                let seen = |h: &Hub| h.log.iter().any(|l| l.starts_with(frame));
                                if c[0] == "Wait For Log Entry" {
                                    while !seen(h) && now < end {
                                        now = now.add_millis(1);
                                        h.run_to(now);
                                    }
                                    assert!(seen(h), "{what}: not among {:#?}", h.log);
                                } else {
                                    h.run_to(end);
                                    assert!(!seen(h), "{what}: {:#?}", h.log);
                                    now = end;
                                }
                                hubs.values_mut().for_each(|h| h.run_to(now));
                                replayed += 1;
                            }
                            // Only the watchdog test's minute passes time elsewhere.
                            _ if c[0] == "Should Not Be In Log" && !pattern.starts_with("CAN ") => {
                                now = end;
                                hubs.values_mut().for_each(|h| h.run_to(now));
                            }
                            _ => {}
                        }
                    }
                    "Clear Log Tester History" => hubs.values_mut().for_each(|h| h.log.clear()),
                    "Create CAN Tester" => tester = Some(c[1].clone()),
                    "Wait For Frame With Id" => {
                        let hub = tester.clone().expect("a CAN tester");
                        let id = number(c[1].trim_start_matches("${").trim_end_matches('}'));
                        let prefix = format!("{id:03X} [");
                        let end = now.add_millis(timeout_ms(c));
                        if let Some(h) = hubs.get_mut(&hub) {
                            while !h.log.iter().any(|l| l.starts_with(&prefix)) && now < end {
                                now = now.add_millis(1);
                                h.run_to(now);
                            }
                            assert!(h.log.iter().any(|l| l.starts_with(&prefix)), "{what}: not among {:#?}", h.log);
                            replayed += 1;
                        }
                    }
                    "Assert LED Is Blinking" | "Assert And Hold LED State" => {
                        let secs: f64 = ["testDuration", "timeoutAssert", "timeoutHold"]
                            .iter()
                            .filter_map(|k| named_arg(c, k))
                            .map(|v| v.parse::<f64>().unwrap())
                            .sum();
                        now = now.add_millis((secs * 1000.0) as u64);
                        hubs.values_mut().for_each(|h| h.run_to(now));
                    }
                    _ => {}
                }
            }
        }
    }
    // Every test's frames (the LSS test's up to the scan): 85 waits when this was written.
    assert!(replayed >= 85, "{replayed} steps replayed");
}
