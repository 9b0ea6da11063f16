*** Settings ***
Documentation       The firmware of all five devices on emulated STM32F103CB boards (renode/README.md):
...                 the CANopen SGH10, SGH50, WV5800M and AP10T, the SAE J1939 WV58MR. Run from the
...                 repository root, after `cargo firmware`:
...                 renode-test renode/tests/bench.robot
...
...                 Frames on a hub are observed through the `can_trace` command of renode/canopen.py,
...                 which logs each one as "CAN <hub> <id> [<length>] <data> from <sender>", and matched
...                 with Wait For Log Entry; frames are sent with its `can_send` command. Expected
...                 values come from the devices' dictionaries (eds/*.eds, generated from od-core) and
...                 CiA 301: boot-up 700h+node [1] 00; expedited upload response 43h (4 data bytes);
...                 download response 60h; heartbeat state 7Fh PRE-OPERATIONAL, 05h OPERATIONAL;
...                 NMT start 01h; PDOs only in OPERATIONAL. The J1939 frames (29-bit identifiers,
...                 8 hex digits in the trace) are those of the od-core J1939 node for the same
...                 boards: tests-host/tests/renode_files.rs runs the WV58MR pairs and the AP10T
...                 on the virtual bus and fails when a frame waited for here is not among theirs.
...                 Renode's default Test Setup (Reset Emulation) runs before each test.

*** Variables ***
${FIRMWARE}                 ${CURDIR}/../../firmware/target/thumbv7m-none-eabi/release
${FILES}                    ${CURDIR}/..
${TIMEOUT}                  5

# SDO upload request of 1000h sub 0 (device type)
${READ_DEVICE_TYPE}         40 00 10 00 00 00 00 00
# SDO expedited download of 2 bytes (command 2Bh) to 1017h sub 0: producer heartbeat 100 ms
${HEARTBEAT_100_MS}         2B 17 10 00 64 00 00 00
# NMT "start remote node" (01h) to all nodes (node-ID 0)
${NMT_START_ALL}            01 00
# 1000h default of the SGH10 and the SGH50 (eds/SGH10.eds, eds/SGH50.eds): 0x000A0196,
# little-endian in the response
${SGH_DEVICE_TYPE}          96 01 0A 00
# 1000h default of the multiturn WV5800M (eds/WV5800M.eds): 0x00020196
${WV_MULTITURN_TYPE}        96 01 02 00
# SDO expedited download of 4 bytes (23h) to 1010h sub 1: "save" (73 61 76 65), all parameters
${SAVE_ALL}                 23 10 10 01 73 61 76 65
# SDO upload request of 1017h sub 0 (producer heartbeat time)
${READ_HEARTBEAT}           40 17 10 00 00 00 00 00
# NMT "reset communication" (82h) to all nodes
${NMT_RESET_COMM_ALL}       82 00
# LSS (CiA 305, on 7E5h): switch state global configuration / waiting, configure node-ID FFh
# ("not configured", docs/decisions.md D-LSS-5)
${LSS_CONFIGURATION}        04 01 00 00 00 00 00 00
${LSS_WAITING}              04 00 00 00 00 00 00 00
${LSS_UNCONFIGURE}          11 FF 00 00 00 00 00 00
# The serial numbers of the SGH50 pair of sgh50.resc from a blank flash: CRC-32 of the unique
# IDs the script gives sgh50a and sgh50b (docs/decisions.md D-FW-3;
# tests-host/tests/renode_images.rs checks them against the script)
${SGH50A_SERIAL}            62552812
${SGH50B_SERIAL}            F9F0647D
# 1000h default of the AP10T (eds/AP10T.eds): 0x00000196
${AP10T_DEVICE_TYPE}        96 01 00 00
# NMT "enter PRE-OPERATIONAL" (80h) to all nodes: a master's ordinary traffic. An AP10T that
# detects the bit rate (as shipped, D-AP-20) ends the detection on the first frame it hears and
# does not otherwise handle that frame.
${NMT_PRE_OPERATIONAL_ALL}  80 00
# The WV58MR pair of wv58mr.resc from a blank flash: the NAME (Address Claimed data, LSB first)
# of each channel, its identity number the low 21 bits of the serial number the unique ID gives
# (wv58mra 9559560Ah, wv58mrb 0EFC1A65h; D-J1939-6, D-FW-3). wv58mra's is the lower NAME.
${WV58MRA_NAME}             0A 56 39 8E 00 8E 00 B0
${WV58MRB_NAME}             65 1A 3C 8E 00 8E 00 B0
# The pair of bus.resc: serial numbers 1000050 and 1000051 from their parameter images.
${WV58MR_1000050_NAME}      72 42 2F 8E 00 8E 00 B0
${WV58MR_1000051_NAME}      73 42 2F 8E 00 8E 00 B0
# EPOS (PGN FC5Fh) of the fed sensor: turns 1, angle 4096 = raw 5000h (1 x 16384 + 4096),
# position = raw at the default scaling; bytes 4..7 FFh. ESPD (FC61h) at rest: speed 0.
${EPOS_FED}                 00 50 00 00 FF FF FF FF
${ESPD_AT_REST}             00 00 FF FF FF FF FF FF
# CAM21 (PGN 0600h, priority 7) from address 00h to EFh: identifier 1C06EF00h; the answer comes
# on CAM11 (0500h) from EFh to 00h: 1C0500EFh (D-J1939-2)
${CAM21_TO_EF}              0x1C06EF00

*** Keywords ***
Load Bus Commands
    Execute Command         include @${FILES}/canopen.py

Create SGH10
    Execute Command         $global.sgh10_bin=@${FIRMWARE}/sgh10
    Execute Command         include @${FILES}/sgh10.resc
    Execute Command         can_trace "canSgh10"

Create Redundant SGH50
    Execute Command         $global.sgh50_bin=@${FIRMWARE}/sgh50
    Execute Command         include @${FILES}/sgh50.resc
    Execute Command         can_trace "canSgh50"
    # Two machines on one hub: execute them serially for a deterministic order, as Renode's
    # own multi-machine CAN tests do (tests/peripherals/IMX8MP_Flexcan.robot).
    Execute Command         emulation SetGlobalSerialExecution True

Create WV5800M
    Execute Command         $global.wv5800m_bin=@${FIRMWARE}/wv5800m
    Execute Command         include @${FILES}/wv5800m.resc
    Execute Command         can_trace "canWv5800m"

Create AP10T
    Execute Command         $global.ap10t_bin=@${FIRMWARE}/ap10t
    Execute Command         include @${FILES}/ap10t.resc
    Execute Command         can_trace "canAp10t"

Create Redundant WV58MR
    Execute Command         $global.wv58mr_bin=@${FIRMWARE}/wv58mr
    Execute Command         include @${FILES}/wv58mr.resc
    Execute Command         can_trace "canWv58mr"
    Execute Command         emulation SetGlobalSerialExecution True

Set Every Binary
    Execute Command         $global.sgh10_bin=@${FIRMWARE}/sgh10
    Execute Command         $global.sgh50_bin=@${FIRMWARE}/sgh50
    Execute Command         $global.wv5800m_bin=@${FIRMWARE}/wv5800m
    Execute Command         $global.ap10t_bin=@${FIRMWARE}/ap10t
    Execute Command         $global.wv58mr_bin=@${FIRMWARE}/wv58mr

Create Bus
    Load Bus Commands
    Set Every Binary
    Execute Command         include @${FILES}/bus.resc
    Execute Command         can_trace "can0"
    Execute Command         can_trace "can1"

Feed Sensor
    [Arguments]             ${machine}
    # A valid reading (turns 1, angle 4096, no error) for the first 20000 samples, queued
    # before the emulation starts so that the firmware reads whole frames from the start.
    Execute Command         sensor_feed "${machine}" 1 4096 20000

Send Frame
    [Arguments]             ${hub}    ${id}    ${data}=${EMPTY}
    Execute Command         can_send "${hub}" ${id} "${data}"

Send Frame Ext
    [Arguments]             ${hub}    ${id}    ${data}=${EMPTY}
    # A 29-bit identifier (J1939).
    Execute Command         can_send_ext "${hub}" ${id} "${data}"

Wait For Frame
    [Arguments]             ${hub}    ${frame}    ${timeout}=${TIMEOUT}
    # keep=True: frames of two nodes may come in either order; each pattern is unique in a test
    # (or the history is cleared in between).
    Wait For Log Entry      CAN ${hub} ${frame}    timeout=${timeout}    keep=True

*** Test Cases ***
SGH10 Should Send Its Boot-up Frame
    Create Log Tester       ${TIMEOUT}
    Load Bus Commands
    Create SGH10
    # Renode's CAN Tester keywords (src/Renode/RobotFrameworkEngine/CANKeywords.cs) see the
    # frame on the hub; the trace line shows its data.
    Create CAN Tester       canSgh10    ${TIMEOUT}
    Wait For Frame With Id  ${0x701}
    Wait For Frame          canSgh10    701 [1] 00

SGH10 Should Answer An SDO Upload Of Its Device Type
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create SGH10
    Wait For Frame          canSgh10    701 [1] 00
    Send Frame              canSgh10    0x601    ${READ_DEVICE_TYPE}
    Wait For Frame          canSgh10    581 [8] 43 00 10 00 ${SGH_DEVICE_TYPE}

SGH10 Should Send TPDO2 On SYNC Only After NMT Start
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create SGH10
    Feed Sensor             sgh10
    Wait For Frame          canSgh10    701 [1] 00
    Send Frame              canSgh10    0x601    ${HEARTBEAT_100_MS}
    # Bytes 4..7 of a download response are reserved: only the command and the address are checked.
    Wait For Frame          canSgh10    581 [8] 60 17 10 00
    Wait For Frame          canSgh10    701 [1] 7F
    # SYNC (COB-ID 1005h = 80h, no data) in PRE-OPERATIONAL: no PDO.
    Send Frame              canSgh10    0x080
    Should Not Be In Log    CAN canSgh10 281    timeout=0.5
    Send Frame              canSgh10    0x000    ${NMT_START_ALL}
    Wait For Frame          canSgh10    701 [1] 05
    # TPDO2: COB-ID 280h + node-ID, transmission type 1 (every SYNC), mapping 6020h.01 (32 bits)
    # + 6030h.01 (16 bits) = 6 data bytes. The position value itself is not checked.
    Send Frame              canSgh10    0x080
    Wait For Frame          canSgh10    281 [6]

Redundant SGH50 Should Boot Both Channels And Answer On Nodes 1 And 2
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create Redundant SGH50
    Wait For Frame          canSgh50    701 [1] 00
    Wait For Frame          canSgh50    702 [1] 00
    Send Frame              canSgh50    0x601    ${READ_DEVICE_TYPE}
    Wait For Frame          canSgh50    581 [8] 43 00 10 00 ${SGH_DEVICE_TYPE}
    Send Frame              canSgh50    0x602    ${READ_DEVICE_TYPE}
    Wait For Frame          canSgh50    582 [8] 43 00 10 00 ${SGH_DEVICE_TYPE}

Redundant SGH50 Should Send TPDO2 From Both Channels On One SYNC
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create Redundant SGH50
    Feed Sensor             sgh50a
    Feed Sensor             sgh50b
    Wait For Frame          canSgh50    701 [1] 00
    Wait For Frame          canSgh50    702 [1] 00
    # NMT start and SYNC reach each node's receive FIFO in this order.
    Send Frame              canSgh50    0x000    ${NMT_START_ALL}
    Send Frame              canSgh50    0x080
    Wait For Frame          canSgh50    281 [6]
    Wait For Frame          canSgh50    282 [6]

WV5800M Should Answer An SDO Upload Of Its Device Type
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create WV5800M
    Wait For Frame          canWv5800m    701 [1] 00
    Send Frame              canWv5800m    0x601    ${READ_DEVICE_TYPE}
    Wait For Frame          canWv5800m    581 [8] 43 00 10 00 ${WV_MULTITURN_TYPE}

WV5800M Should Flash Its Green LED Until NMT Start
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create WV5800M
    ${green}=               Create LED Tester    sysbus.gpioPortB.ledGreen    machine=wv5800m
    ${red}=                 Create LED Tester    sysbus.gpioPortB.ledRed      machine=wv5800m
    Wait For Frame          canWv5800m    701 [1] 00
    Send Frame              canWv5800m    0x601    ${HEARTBEAT_100_MS}
    Wait For Frame          canWv5800m    581 [8] 60 17 10 00
    # PRE-OPERATIONAL: green flashing, 200 ms on, 200 ms off (CiA 303-3; od-core/src/led.rs).
    Assert Led Is Blinking  testDuration=2    onDuration=0.2    offDuration=0.2    tolerance=0.1    testerId=${green}
    # No CAN error in the emulation (the STMCAN model's error counters stay 0): red off.
    Assert And Hold Led State    false    timeoutAssert=0    timeoutHold=1    testerId=${red}
    Send Frame              canWv5800m    0x000    ${NMT_START_ALL}
    Wait For Frame          canWv5800m    701 [1] 05
    # Give the LED task time to follow the state (at most one flash period), then OPERATIONAL:
    # green on.
    Execute Command         pause
    Execute Command         emulation RunFor "0.5"
    Assert And Hold Led State    true    timeoutAssert=0    timeoutHold=1    testerId=${green}

Bench Should Boot Every Device
    Create Log Tester       ${TIMEOUT}
    Set Every Binary
    # bench.resc loads canopen.py, traces its five hubs and starts the emulation.
    Execute Command         include @${FILES}/bench.resc
    Wait For Frame          canSgh10    701 [1] 00
    Wait For Frame          canSgh50    701 [1] 00
    Wait For Frame          canSgh50    702 [1] 00
    Wait For Frame          canWv5800m    701 [1] 00
    # The WV58MR pair: EFh to the lower NAME, 80h to the other.
    Wait For Frame          canWv58mr    18EEFFEF [8] ${WV58MRA_NAME}
    Wait For Frame          canWv58mr    18EEFF80 [8] ${WV58MRB_NAME}
    Wait For Frame          canWv58mr    0CFC5FEF [8]
    Wait For Frame          canWv58mr    0CFC5F80 [8]
    # The AP10T alone on its hub hears nothing until a frame is sent there.
    Should Not Be In Log    CAN canAp10t    timeout=0
    Send Frame              canAp10t    0x000    ${NMT_PRE_OPERATIONAL_ALL}
    Wait For Frame          canAp10t    77D [1] 00

One Bus Should Carry The Simulator's Bench With Stored Node-IDs
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Create Bus
    Feed Sensor             wv58mr-1000050
    Feed Sensor             wv58mr-1000051
    # The node-IDs come from the parameter pages (renode/images), the SGH50's channel from its
    # straps: four nodes, four boot-ups on one bus.
    Wait For Frame          can0    70A [1] 00
    Wait For Frame          can0    714 [1] 00
    Wait For Frame          can0    715 [1] 00
    Wait For Frame          can0    71E [1] 00
    Send Frame              can0    0x60A    ${READ_DEVICE_TYPE}
    Wait For Frame          can0    58A [8] 43 00 10 00 ${SGH_DEVICE_TYPE}
    Send Frame              can0    0x61E    ${READ_DEVICE_TYPE}
    Wait For Frame          can0    59E [8] 43 00 10 00 ${WV_MULTITURN_TYPE}
    # The serial numbers are the programmed ones (1018h sub 4 = 1000010 = 000F424Ah).
    Send Frame              can0    0x60A    40 18 10 04 00 00 00 00
    Wait For Frame          can0    58A [8] 43 18 10 04 4A 42 0F 00
    # The AP10T (node-ID 40 = 28h from its image, bit rate detected) boots up once it heard
    # a frame on can0; the frames above were such frames.
    Wait For Frame          can0    728 [1] 00
    Send Frame              can0    0x628    ${READ_DEVICE_TYPE}
    Wait For Frame          can0    5A8 [8] 43 00 10 00 ${AP10T_DEVICE_TYPE}
    # can1, the J1939 bus: serial number 1000050's NAME is the lower and keeps EFh.
    Wait For Frame          can1    18EEFFEF [8] ${WV58MR_1000050_NAME}
    Wait For Frame          can1    18EEFF80 [8] ${WV58MR_1000051_NAME}
    Wait For Frame          can1    0CFC5FEF [8] ${EPOS_FED}
    Wait For Frame          can1    0CFC5F80 [8] ${EPOS_FED}

SGH10 Should Keep A Stored Parameter Over A Machine Reset
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create SGH10
    Wait For Frame          canSgh10    701 [1] 00
    Send Frame              canSgh10    0x601    ${HEARTBEAT_100_MS}
    Wait For Frame          canSgh10    581 [8] 60 17 10 00
    # 1010h sub 1 "save": the answer comes once the parameter pages are written (D-FW-9).
    Send Frame              canSgh10    0x601    ${SAVE_ALL}
    Wait For Frame          canSgh10    581 [8] 60 10 10 01
    # A reset of the machine (the CPU and every peripheral; the reset macro reloads the ELF, the
    # flash memory keeps its contents, as a power cycle keeps the chip's flash). The history is
    # cleared first, so the boot-up and heartbeat below can only be the new ones.
    Clear Log Tester History
    Execute Command         mach set "sgh10"
    Execute Command         machine Reset
    Wait For Frame          canSgh10    701 [1] 00
    # 1017h defaults to 0 (no heartbeat): a heartbeat without being asked is the stored 100 ms.
    Wait For Frame          canSgh10    701 [1] 7F
    Send Frame              canSgh10    0x601    ${READ_HEARTBEAT}
    Wait For Frame          canSgh10    581 [8] 4B 17 10 00 64 00 00 00

LSS Fastscan Should Find Both SGH50 Boards By Their Serial Numbers
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create Redundant SGH50
    Execute Command         emulation SetGlobalAdvanceImmediately True
    Wait For Frame          canSgh50    701 [1] 00
    Wait For Frame          canSgh50    702 [1] 00
    # Both boards lose their node-ID: configuration state, pending node-ID FFh (both answer
    # 11h 00h), waiting, then NMT reset communication activates it (D-LSS-5, D-LSS-7). A node
    # without node-ID is silent but for LSS.
    Send Frame              canSgh50    0x7E5    ${LSS_CONFIGURATION}
    Send Frame              canSgh50    0x7E5    ${LSS_UNCONFIGURE}
    Wait For Frame          canSgh50    7E4 [8] 11 00 00 00 00 00 00 00
    Send Frame              canSgh50    0x7E5    ${LSS_WAITING}
    Send Frame              canSgh50    0x000    ${NMT_RESET_COMM_ALL}
    Execute Command         pause
    Execute Command         emulation RunFor "0.1"
    Clear Log Tester History
    # Fastscan tells the two boards apart by their LSS addresses, which differ in the serial
    # number only: each board's is derived from its own unique ID (sgh50.resc). With one ID for
    # both (the unmodelled system memory read 0: serial 7BD5C66Fh twice) both boards answer
    # every step alike, both take the first node-ID and the scan fails.
    Execute Command         lss_fastscan "canSgh50" 0x20
    Wait For Log Entry      LSS fastscan canSgh50: found serial ${SGH50A_SERIAL}    timeout=10    keep=True
    Wait For Log Entry      LSS fastscan canSgh50: found serial ${SGH50B_SERIAL}    timeout=10    keep=True
    Wait For Log Entry      LSS fastscan canSgh50: done, 2 found    timeout=10    keep=True
    Should Not Be In Log    LSS fastscan canSgh50: failed    timeout=0
    # Each found board boots up with the node-ID it was given: 20h for the lower address (the
    # scan asks every bit as 0 first), 21h for the other.
    Wait For Frame          canSgh50    720 [1] 00
    Wait For Frame          canSgh50    721 [1] 00

Five Devices Should Run A Minute Without A Watchdog Reset
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Create Bus
    Execute Command         emulation SetGlobalAdvanceImmediately True
    Wait For Frame          can0    70A [1] 00
    Wait For Frame          can0    714 [1] 00
    Wait For Frame          can0    715 [1] 00
    Wait For Frame          can0    71E [1] 00
    # Every node sends a heartbeat every 100 ms and is OPERATIONAL, so each has the LED,
    # heartbeat and sample deadlines of a working bench. Broadcast SDO is not CANopen: each
    # node is asked on its own.
    Send Frame              can0    0x60A    ${HEARTBEAT_100_MS}
    Send Frame              can0    0x614    ${HEARTBEAT_100_MS}
    Send Frame              can0    0x615    ${HEARTBEAT_100_MS}
    Send Frame              can0    0x61E    ${HEARTBEAT_100_MS}
    # The AP10T has heard those frames and booted up.
    Wait For Frame          can0    728 [1] 00
    Send Frame              can0    0x628    ${HEARTBEAT_100_MS}
    Wait For Frame          can0    5A8 [8] 60 17 10 00
    Send Frame              can0    0x000    ${NMT_START_ALL}
    Wait For Frame          can0    70A [1] 05
    Wait For Frame          can0    714 [1] 05
    Wait For Frame          can0    715 [1] 05
    Wait For Frame          can0    71E [1] 05
    Wait For Frame          can0    728 [1] 05
    # The J1939 pair publishes EPOS and ESPD every 50 ms once its claims stood.
    Wait For Frame          can1    0CFC5FEF [8]
    Wait For Frame          can1    0CFC5F80 [8]
    # Renode's IWDG model logs this (Warning) when it resets a machine. Before the firmware
    # kept its timer alarms off compare value 0 (board_plan::alarm, renode issue 1007) the
    # four CANopen boards were reset 2 to 3 times in 10 to 12 virtual seconds.
    Should Not Be In Log    Watchdog reset triggered!    timeout=60
    # Still alive: every node's heartbeat, and both channels' EPOS, after the minute.
    Clear Log Tester History
    Wait For Frame          can0    70A [1] 05
    Wait For Frame          can0    714 [1] 05
    Wait For Frame          can0    715 [1] 05
    Wait For Frame          can0    71E [1] 05
    Wait For Frame          can0    728 [1] 05
    Wait For Frame          can1    0CFC5FEF [8]
    Wait For Frame          can1    0CFC5F80 [8]

AP10T Should Stay Silent Until It Hears A Frame, Then Boot Up
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create AP10T
    # As shipped it detects the bit rate (D-AP-20): it listens silent, 1 s at each of five
    # rates. Three virtual seconds without a frame on the hub: three rate switches, no boot-up.
    Should Not Be In Log    CAN canAp10t    timeout=3
    # The first frame ends the detection (in Renode at whatever rate it listens: the model has
    # no bit timing); the boot-up follows: node-ID 7Dh as shipped.
    Send Frame              canAp10t    0x000    ${NMT_PRE_OPERATIONAL_ALL}
    Wait For Frame          canAp10t    77D [1] 00
    Send Frame              canAp10t    0x67D    ${READ_DEVICE_TYPE}
    Wait For Frame          canAp10t    5FD [8] 43 00 10 00 ${AP10T_DEVICE_TYPE}

Redundant WV58MR Should Claim Two Addresses And Publish EPOS
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create Redundant WV58MR
    Feed Sensor             wv58mra
    Feed Sensor             wv58mrb
    # Both channels start at EFh and claim it after the delay their NAME gives (D-J1939-13):
    # wv58mrb first, then wv58mra, whose NAME is the lower; wv58mrb loses and claims 80h
    # (D-J1939-1, -4). Address Claimed: PGN EE00h, priority 6, to FFh.
    Wait For Frame          canWv58mr    18EEFFEF [8] ${WV58MRB_NAME}
    Wait For Frame          canWv58mr    18EEFFEF [8] ${WV58MRA_NAME}
    Wait For Frame          canWv58mr    18EEFF80 [8] ${WV58MRB_NAME}
    # 250 ms after its claim each channel publishes EPOS (FC5Fh) and ESPD (FC61h), priority 3,
    # every 50 ms (D-J1939-10).
    Wait For Frame          canWv58mr    0CFC5FEF [8] ${EPOS_FED}
    Wait For Frame          canWv58mr    0CFC5F80 [8] ${EPOS_FED}
    Wait For Frame          canWv58mr    0CFC61EF [8] ${ESPD_AT_REST}
    Wait For Frame          canWv58mr    0CFC6180 [8] ${ESPD_AT_REST}
    # Parameter access through the controller's 29-bit mask filters: CAM21 from 00h to EFh,
    # an SDO upload of 1000h; the answer on CAM11 from EFh to 00h: the 12-bit multiturn's
    # 00020196h.
    Send Frame Ext          canWv58mr    ${CAM21_TO_EF}    ${READ_DEVICE_TYPE}
    Wait For Frame          canWv58mr    1C0500EF [8] 43 00 10 00 ${WV_MULTITURN_TYPE}

WV58MR Should Keep A Stored Address Over A Machine Reset
    Create Log Tester       ${TIMEOUT}    defaultPauseEmulation=true
    Load Bus Commands
    Create Redundant WV58MR
    Wait For Frame          canWv58mr    0CFC5FEF [8]
    # 5F0Ah.01, the address, = 90h (UNSIGNED8, expedited 2Fh) over CAM21 to EFh (wv58mra); it
    # takes effect at the next start (D-J1939-21). Then 1010h.01 "save", answered once the
    # parameter pages are written (the flash interface stand-in, as for the SGH10).
    Send Frame Ext          canWv58mr    ${CAM21_TO_EF}    2F 0A 5F 01 90 00 00 00
    Wait For Frame          canWv58mr    1C0500EF [8] 60 0A 5F 01
    Send Frame Ext          canWv58mr    ${CAM21_TO_EF}    ${SAVE_ALL}
    Wait For Frame          canWv58mr    1C0500EF [8] 60 10 10 01
    # A reset of wv58mra (the reset macro reloads the ELF; the flash keeps the pages): it claims
    # the stored address with its own NAME and publishes from there; wv58mrb stays at 80h.
    Clear Log Tester History
    Execute Command         mach set "wv58mra"
    Execute Command         machine Reset
    Wait For Frame          canWv58mr    18EEFF90 [8] ${WV58MRA_NAME}
    Wait For Frame          canWv58mr    0CFC5F90 [8]
    Wait For Frame          canWv58mr    0CFC5F80 [8]
