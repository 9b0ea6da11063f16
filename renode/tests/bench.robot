# The SIKO firmware on Renode: four boards on one CAN hub (renode/machines.resc), watched and
# driven by Renode's CAN tester. Run with `renode-test renode/tests/bench.robot` after
# `cargo firmware`. The tester has no keyword for a raw frame, but `Send ISOTP Message` with up
# to seven bytes sends one unpadded frame of the length byte and the bytes (CANTester.cs), which
# is how the frames below are made: `00` on 000h is the NMT frame 01 00, an empty message on
# 080h a SYNC with one byte.

*** Variables ***
${MACHINES}                 @${CURDIR}/../machines.resc

*** Keywords ***
Start Bench
    Execute Command         include ${MACHINES}
    Create CAN Tester       canHub
    Start Emulation

Frame Should Be
    [Arguments]             ${id}    ${expected}
    ${data}=                Wait For Frame With Id    ${id}    timeout=5
    ${hex}=                 Evaluate    ''.join('%02X' % b for b in $data)
    Should Be Equal         ${hex}    ${expected}

*** Test Cases ***
Every Node Sends Its Boot-Up Message
    Start Bench
    # 700h + node-ID, one byte 00h (CiA 301): the node-IDs come from the parameter pages, the
    # SGH50's channel from its straps.
    Frame Should Be         ${{0x70A}}    00
    Frame Should Be         ${{0x714}}    00
    Frame Should Be         ${{0x715}}    00
    Frame Should Be         ${{0x71E}}    00

The SDO Server Aborts A Segment Outside A Transfer
    Start Bench
    Frame Should Be         ${{0x70A}}    00
    # The frame 07 40 00 10 00 00 00 00 to 60Ah is a download segment (command specifier 0)
    # with no download under way: the server aborts it with 05040001h (command specifier not
    # valid), index and sub-index 0.
    Send ISOTP Message      ${{0x60A}}    ${{0x58A}}    40001000000000
    Frame Should Be         ${{0x58A}}    8000000001000405

NMT Start And SYNC Make The Encoders Send Their Synchronous TPDO
    Start Bench
    Frame Should Be         ${{0x70A}}    00
    Frame Should Be         ${{0x71E}}    00
    # NMT 01 00: every node to OPERATIONAL.
    Send ISOTP Message      ${{0x000}}    ${{0x7FF}}    00
    # SYNC (080h, one counter byte).
    Send ISOTP Message      ${{0x080}}    ${{0x7FF}}    ${EMPTY}
    # TPDO2 of the SGH10 (node 10) is synchronous: position value (4 bytes) and speed (2).
    ${tpdo}=                Wait For Frame With Id    ${{0x28A}}    timeout=5
    Length Should Be        ${tpdo}    6

The WV5800M's Green LED Is Steady On In OPERATIONAL
    Start Bench
    Frame Should Be         ${{0x71E}}    00
    Create LED Tester       sysbus.gpioPortB.greenLed    machine=wv5800m-node30
    # NMT 01 1E: node 30 to OPERATIONAL; CiA 303-3 green: on (flashing in PRE-OPERATIONAL).
    Send ISOTP Message      ${{0x000}}    ${{0x7FF}}    1E
    Assert And Hold Led State    true    timeoutAssert=1    timeoutHold=0.5
