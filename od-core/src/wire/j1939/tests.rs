//! Byte-for-byte tests of the J1939 wire formats against every frame the WV58MR manual prints
//! (§5.5.3, E1-E3 of the digest) and the digest's derived vectors (§6.2, D1-D26), and
//! property tests that no input panics a parser.

use super::*;

/// Parse a received frame into (identifier, payload).
fn rx(id: u32, data: &[u8]) -> (Identifier, Frame) {
    let frame = Frame::new(CanId::Ext(id), data);
    (Identifier::from_frame(&frame).unwrap(), frame)
}

fn prio(p: u8) -> Priority {
    Priority::new(p).unwrap()
}

// ---- the manual's three examples (§5.5.3) ----

#[test]
fn e1_read_calibration_value() {
    // Request as printed, "x" bytes sent as 00h and as anything else.
    for pad in [0x00, 0xAA, 0xFF] {
        let (id, f) = rx(0x1C06_EF00, &[0x40, 0x03, 0x60, 0x00, pad, pad, pad, pad]);
        assert_eq!(id.priority(), prio(7));
        assert_eq!(id.pgn(), Pgn::CAM21);
        assert_eq!(id.destination(), Some(Address(0xEF)));
        assert_eq!(id.source(), Address(0x00));
        assert_eq!(CamRequest::parse(f.payload()), Ok(CamRequest::Read { index: 0x6003, sub: 0 }));
    }
    let req = CamRequest::Read { index: 0x6003, sub: 0 };
    assert_eq!(
        req.frame(Address(0xEF), Address(0x00)),
        Frame::new(CanId::Ext(0x1C06_EF00), &[0x40, 3, 0x60, 0, 0, 0, 0, 0])
    );

    // Response as printed: 43h, value FEh 01h (510; the text's 530 is A5).
    let resp = CamResponse::Read { index: 0x6003, sub: 0, value: 0x1FE, len: 4 };
    let expect = Frame::new(CanId::Ext(0x1C05_00EF), &[0x43, 0x03, 0x60, 0x00, 0xFE, 0x01, 0x00, 0x00]);
    assert_eq!(resp.frame(Address(0x00), Address(0xEF)), expect);
    let (id, f) = rx(0x1C05_00EF, expect.payload());
    assert_eq!((id.pgn(), id.destination(), id.source()), (Pgn::CAM11, Some(Address(0)), Address(0xEF)));
    assert_eq!(CamResponse::parse(f.payload()), Ok(resp));
}

#[test]
fn e2_write_position_cycle_time() {
    let (id, f) = rx(0x1C06_4A00, &[0x2B, 0x00, 0x30, 0x03, 0x64, 0x00, 0x00, 0x00]);
    assert_eq!((id.pgn(), id.destination(), id.source()), (Pgn::CAM21, Some(Address(0x4A)), Address(0)));
    let req = CamRequest::Write { index: 0x3000, sub: 3, value: 100, len: Some(2) };
    assert_eq!(CamRequest::parse(f.payload()), Ok(req));
    // The "x" bytes are not part of the value.
    assert_eq!(CamRequest::parse(&[0x2B, 0x00, 0x30, 0x03, 0x64, 0x00, 0x12, 0x34]), Ok(req));
    assert_eq!(req.frame(Address(0x4A), Address(0)), f);

    let resp = CamResponse::Written { index: 0x3000, sub: 3 };
    assert_eq!(
        resp.frame(Address(0), Address(0x4A)),
        Frame::new(CanId::Ext(0x1C05_004A), &[0x60, 0x00, 0x30, 0x03, 0, 0, 0, 0])
    );
    assert_eq!(CamResponse::parse(&resp.emit()), Ok(resp));
}

#[test]
fn e3_store_all_parameters() {
    let save = [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65];
    let (id, f) = rx(0x1C06_4A00, &save);
    assert_eq!(id.destination(), Some(Address(0x4A)));
    let req = CamRequest::Write { index: 0x1010, sub: 1, value: 0x6576_6173, len: Some(4) };
    assert_eq!(CamRequest::parse(f.payload()), Ok(req));
    assert_eq!(req.emit(), save);
    assert_eq!(
        CamResponse::Written { index: 0x1010, sub: 1 }.frame(Address(0), Address(0x4A)),
        Frame::new(CanId::Ext(0x1C05_004A), &[0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0])
    );
}

// ---- the digest's derived vectors (§6.2) ----

#[test]
fn d1_to_d3_d6_d22_process_data() {
    let ea = Address(0xEF);
    let epos = Identifier::pdu2(prio(3), Pgn::EPOS, ea).unwrap();
    assert_eq!(epos.emit(), 0x0CFC_5FEF);
    assert_eq!(
        epos.frame(&Epos { position: 0x12345 }.emit()),
        Frame::new(CanId::Ext(0x0CFC_5FEF), &[0x45, 0x23, 0x01, 0x00, 0xFF, 0xFF, 0xFF, 0xFF])
    );
    let espd = Identifier::pdu2(prio(3), Pgn::ESPD, ea).unwrap();
    assert_eq!(espd.emit(), 0x0CFC_61EF);
    assert_eq!(Espd { speed: 100 }.emit(), [0x64, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(Espd { speed: -2 }.emit(), [0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(Espd::parse(&[0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]), Ok(Espd { speed: -2 }));

    let prop = Identifier::pdu2(prio(6), Pgn::PROPRIETARY_B, ea).unwrap();
    assert_eq!(prop.emit(), 0x18FF_AAEF);
    let b = ProprietaryB { position: 0x12345, speed: 100 };
    assert_eq!(b.emit(), [0x45, 0x23, 0x01, 0x00, 0x64, 0x00, 0x00, 0x00]);
    assert_eq!(ProprietaryB::parse(&b.emit()), Ok(b));

    // D22: EPOS at priority 2.
    assert_eq!(Identifier::pdu2(prio(2), Pgn::EPOS, ea).unwrap().emit(), 0x08FC_5FEF);

    let (id, f) = rx(0x0CFC_5FEF, &[0x45, 0x23, 0x01, 0x00, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!((id.pgn(), id.destination(), id.priority()), (Pgn::EPOS, None, prio(3)));
    assert_eq!(Epos::parse(f.payload()), Ok(Epos { position: 0x12345 }));
}

#[test]
fn d4_to_d21_parameter_access() {
    let dev = Address(0xEF);
    let master = Address(0x00);
    let cases: &[(CamRequest, [u8; 8])] = &[
        (
            CamRequest::Write { index: 0x3000, sub: 1, value: 100, len: Some(2) },
            [0x2B, 0x00, 0x30, 0x01, 0x64, 0, 0, 0],
        ),
        (CamRequest::Read { index: 0x3000, sub: 2 }, [0x40, 0x00, 0x30, 0x02, 0, 0, 0, 0]),
        (CamRequest::Read { index: 0x5F0A, sub: 1 }, [0x40, 0x0A, 0x5F, 0x01, 0, 0, 0, 0]),
        (CamRequest::Read { index: 0x1000, sub: 0 }, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]),
        (CamRequest::Read { index: 0x1018, sub: 1 }, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
        (
            CamRequest::Write { index: 0x6003, sub: 0, value: 530, len: Some(4) },
            [0x23, 0x03, 0x60, 0x00, 0x12, 0x02, 0, 0],
        ),
        (
            CamRequest::Write { index: 0x1011, sub: 1, value: 0x6461_6F6C, len: Some(4) },
            [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64],
        ),
        (
            CamRequest::Write { index: 0x5F0A, sub: 1, value: 0x80, len: Some(1) },
            [0x2F, 0x0A, 0x5F, 0x01, 0x80, 0, 0, 0],
        ),
        (
            CamRequest::Write { index: 0x1010, sub: 4, value: 0x6576_6173, len: Some(4) },
            [0x23, 0x10, 0x10, 0x04, 0x73, 0x61, 0x76, 0x65],
        ),
        (CamRequest::Write { index: 0x3002, sub: 2, value: 1, len: Some(1) }, [0x2F, 0x02, 0x30, 0x02, 0x01, 0, 0, 0]),
        (CamRequest::Write { index: 0x3000, sub: 6, value: 2, len: Some(1) }, [0x2F, 0x00, 0x30, 0x06, 0x02, 0, 0, 0]),
    ];
    for (req, bytes) in cases {
        assert_eq!(req.frame(dev, master), Frame::new(CanId::Ext(0x1C06_EF00), bytes), "{req:?}");
        assert_eq!(CamRequest::parse(bytes), Ok(*req));
    }
    let responses: &[(CamResponse, [u8; 8])] = &[
        (CamResponse::Written { index: 0x3000, sub: 1 }, [0x60, 0x00, 0x30, 0x01, 0, 0, 0, 0]),
        (CamResponse::Read { index: 0x3000, sub: 2, value: 50, len: 2 }, [0x4B, 0x00, 0x30, 0x02, 0x32, 0, 0, 0]),
        (CamResponse::Read { index: 0x5F0A, sub: 1, value: 0xEF, len: 1 }, [0x4F, 0x0A, 0x5F, 0x01, 0xEF, 0, 0, 0]),
        (
            CamResponse::Read { index: 0x1000, sub: 0, value: 0x0002_0196, len: 4 },
            [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x02, 0x00],
        ),
        (CamResponse::Read { index: 0x1018, sub: 1, value: 0x195, len: 4 }, [0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0, 0]),
        (CamResponse::Written { index: 0x6003, sub: 0 }, [0x60, 0x03, 0x60, 0x00, 0, 0, 0, 0]),
        (CamResponse::Written { index: 0x1011, sub: 1 }, [0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]),
        (
            CamResponse::Abort { index: 0x6003, sub: 0, code: 0x0609_0030 },
            [0x80, 0x03, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06],
        ),
    ];
    for (resp, bytes) in responses {
        assert_eq!(resp.frame(master, dev), Frame::new(CanId::Ext(0x1C05_00EF), bytes), "{resp:?}");
        assert_eq!(CamResponse::parse(bytes), Ok(*resp));
    }
}

#[test]
fn d23_to_d25_emergency() {
    let id = Identifier::pdu2(prio(1), Pgn::EMCY, Address(0xEF)).unwrap();
    assert_eq!(id.emit(), 0x04FC_68EF);
    assert_eq!(Emcy { code: 0xFF05, register: 0x81 }.emit(), [0x05, 0xFF, 0x81, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(Emcy { code: 0x8120, register: 0x11 }.emit(), [0x20, 0x81, 0x11, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(Emcy { code: 0, register: 0 }.emit(), [0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(
        Emcy::parse(&[0x05, 0xFF, 0x81, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]),
        Ok(Emcy { code: 0xFF05, register: 0x81 })
    );
}

/// The WV58MR's default NAME fields (3001h) with identity number `id`.
fn wv58mr_name(id: u32) -> NameFields {
    NameFields {
        identity_number: id,
        manufacturer_code: 0x471,
        ecu_instance: 0,
        function_instance: 0,
        function: 0x8E,
        reserved: false,
        vehicle_system: 0,
        vehicle_system_instance: 0,
        industry_group: 3,
        arbitrary_address_capable: true,
    }
}

#[test]
fn d26_address_claimed_with_default_name() {
    let name = Name::from_fields(&wv58mr_name(0x12_3456)).unwrap();
    assert_eq!(name.raw(), 0xB000_8E00_8E20_0000 | 0x12_3456);
    assert_eq!(name.fields(), wv58mr_name(0x12_3456));
    let f = AddressClaimed { name }.frame(Address(0xEF));
    assert_eq!(f, Frame::new(CanId::Ext(0x18EE_FFEF), &[0x56, 0x34, 0x20 | 0x12, 0x8E, 0x00, 0x8E, 0x00, 0xB0]));
    let (id, f) = rx(0x18EE_FFEF, f.payload());
    assert_eq!((id.pgn(), id.destination(), id.source()), (Pgn::ADDRESS_CLAIMED, Some(Address::GLOBAL), Address(0xEF)));
    assert_eq!(AddressClaimed::parse(f.payload()), Ok(AddressClaimed { name }));
    // Cannot Claim: the same message from the null address.
    assert_eq!(AddressClaimed { name }.frame(Address::NULL).id, CanId::Ext(0x18EE_FFFE));
}

#[test]
fn name_fields_are_checked_and_placed() {
    assert_eq!(NameFields::identity_from_serial(0xFFFF_FFFF), 0x1F_FFFF);
    assert_eq!(NameFields::identity_from_serial(1), 1);
    let ok = wv58mr_name(0x1F_FFFF);
    assert!(Name::from_fields(&ok).is_ok());
    for bad in [
        NameFields { identity_number: 0x20_0000, ..ok },
        NameFields { manufacturer_code: 0x800, ..ok },
        NameFields { ecu_instance: 8, ..ok },
        NameFields { function_instance: 0x20, ..ok },
        NameFields { vehicle_system: 0x80, ..ok },
        NameFields { vehicle_system_instance: 0x10, ..ok },
        NameFields { industry_group: 8, ..ok },
    ] {
        assert_eq!(Name::from_fields(&bad), Err(Error::Malformed), "{bad:?}");
    }
    // One field at a time lands on its J1939-81 bits.
    let zero = NameFields::default();
    let single: &[(NameFields, u64)] = &[
        (NameFields { identity_number: 1, ..zero }, 1),
        (NameFields { manufacturer_code: 1, ..zero }, 1 << 21),
        (NameFields { ecu_instance: 1, ..zero }, 1 << 32),
        (NameFields { function_instance: 1, ..zero }, 1 << 35),
        (NameFields { function: 1, ..zero }, 1 << 40),
        (NameFields { reserved: true, ..zero }, 1 << 48),
        (NameFields { vehicle_system: 1, ..zero }, 1 << 49),
        (NameFields { vehicle_system_instance: 1, ..zero }, 1 << 56),
        (NameFields { industry_group: 1, ..zero }, 1 << 60),
        (NameFields { arbitrary_address_capable: true, ..zero }, 1 << 63),
    ];
    for (f, raw) in single {
        assert_eq!(Name::from_fields(f).unwrap().raw(), *raw, "{f:?}");
        assert_eq!(Name::from_raw(*raw).fields(), *f);
    }
    // Arbitration: the lower value wins, equal does not.
    let a = Name::from_raw(0x10);
    let b = Name::from_raw(0x11);
    assert!(a.wins_against(b));
    assert!(!b.wins_against(a));
    assert!(!a.wins_against(a));
    assert!(Name::from_fields(&ok).unwrap().arbitrary_address_capable());
}

// ---- PGN and identifier rules ----

#[test]
fn pgn_rules() {
    assert_eq!(Pgn::new(0xEA00), Some(Pgn::REQUEST));
    assert_eq!(Pgn::new(0xEA01), None, "PDU1 number with a non-zero PS");
    assert_eq!(Pgn::new(0x4_0000), None, "over 18 bits");
    assert_eq!(Pgn::new(0xFC5F), Some(Pgn::EPOS));
    assert_eq!(Pgn::new(0x3_FFFF).map(Pgn::raw), Some(0x3_FFFF));
    assert_eq!(Pgn::pdu1(false, false, 0x06), Some(Pgn::CAM21));
    assert_eq!(Pgn::pdu1(false, false, 0xF0), None);
    assert_eq!(Pgn::pdu2(false, false, 0xFF, 0xAA), Some(Pgn::PROPRIETARY_B));
    assert_eq!(Pgn::pdu2(false, false, 0xEF, 0x00), None);
    let p = Pgn::pdu2(true, true, 0xF0, 0x12).unwrap();
    assert_eq!((p.raw(), p.edp(), p.dp(), p.pf(), p.group_extension()), (0x3_F012, true, true, 0xF0, Some(0x12)));
    assert_eq!(Pgn::CAM11.group_extension(), None);
    assert!(Pgn::ADDRESS_CLAIMED.is_pdu1() && !Pgn::EMCY.is_pdu1());
    for (pgn, dec) in [
        (Pgn::REQUEST, 59904),
        (Pgn::ACKNOWLEDGEMENT, 59392),
        (Pgn::ADDRESS_CLAIMED, 60928),
        (Pgn::CAM11, 1280),
        (Pgn::CAM21, 1536),
        (Pgn::EPOS, 64607),
        (Pgn::ESPD, 64609),
        (Pgn::EMCY, 64616),
        (Pgn::PROPRIETARY_B, 65450),
    ] {
        assert_eq!(pgn.raw(), dec);
    }
}

#[test]
fn identifier_rules() {
    let sa = Address(0x80);
    assert!(Identifier::pdu1(prio(6), Pgn::EPOS, Address(1), sa).is_none());
    assert!(Identifier::pdu2(prio(6), Pgn::REQUEST, sa).is_none());
    assert!(Identifier::new(prio(6), Pgn::REQUEST, None, sa).is_none());
    assert!(Identifier::new(prio(6), Pgn::EPOS, Some(Address(1)), sa).is_none());
    assert_eq!(Priority::new(8), None);
    assert_eq!(Identifier::parse(0x2000_0000), Err(Error::Malformed));
    // Bits 25 and 24 (EDP, DP) go into the PGN.
    let id = Identifier::parse(0x1BEA_12FE).unwrap();
    assert_eq!(
        (id.priority(), id.pgn().raw(), id.destination(), id.source()),
        (prio(6), 0x3_EA00, Some(Address(0x12)), Address::NULL)
    );
    assert_eq!(id.emit(), 0x1BEA_12FE);
    // Not J1939: standard identifiers and remote frames.
    assert_eq!(Identifier::from_frame(&Frame::std(0x123, &[])), Err(Error::Malformed));
    assert_eq!(Identifier::from_frame(&Frame::remote(CanId::Ext(0x18EA_FF00), 3)), Err(Error::Malformed));
    // Addressing.
    let to_ef = Identifier::pdu1(prio(7), Pgn::CAM21, Address(0xEF), Address(0)).unwrap();
    assert!(to_ef.is_for(Address(0xEF)) && !to_ef.is_for(Address(0xEE)));
    let global = Identifier::pdu1(prio(6), Pgn::REQUEST, Address::GLOBAL, Address(0)).unwrap();
    assert!(global.is_for(Address(0xEE)));
    assert!(Identifier::pdu2(prio(3), Pgn::EPOS, Address(0xEF)).unwrap().is_for(Address(0x80)));
    assert!(Address(0xFD).is_unicast() && !Address::NULL.is_unicast() && !Address::GLOBAL.is_unicast());
}

#[test]
fn request_and_acknowledgement() {
    // Request for Address Claimed to everyone from the null address.
    let req = Request { pgn: Pgn::ADDRESS_CLAIMED };
    assert_eq!(req.frame(Address::GLOBAL, Address::NULL), Frame::new(CanId::Ext(0x18EA_FFFE), &[0x00, 0xEE, 0x00]));
    assert_eq!(Request::parse(&[0x00, 0xEE, 0x00]), Ok(req));
    assert_eq!(Request::parse(&[0x5F, 0xFC, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]), Ok(Request { pgn: Pgn::EPOS }));
    assert_eq!(Request::parse(&[0x00, 0xEE]), Err(Error::Length));
    assert_eq!(Request::parse(&[0x01, 0xEE, 0x00]), Err(Error::Malformed));
    assert_eq!(Request::parse(&[0x00, 0xEE, 0x04]), Err(Error::Malformed));

    // NACK of a request for FF00h from 00h, sent to global (D-J1939-5).
    let nack = Acknowledgement::nack(Pgn::new(0xFF00).unwrap(), Address(0x00));
    assert_eq!(
        nack.frame(Address(0xEF)),
        Frame::new(CanId::Ext(0x18E8_FFEF), &[0x01, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0xFF, 0x00])
    );
    assert_eq!(Acknowledgement::parse(&nack.emit()), Ok(nack));
    let ack = Acknowledgement { control: AckControl::Ack, group_function: 3, address: Address(9), pgn: Pgn::EPOS };
    assert_eq!(ack.emit(), [0, 3, 0xFF, 0xFF, 9, 0x5F, 0xFC, 0x00]);
    for (c, control) in [(0, AckControl::Ack), (2, AckControl::AccessDenied), (3, AckControl::CannotRespond)] {
        let b = [c, 0xFF, 0xFF, 0xFF, 1, 0x00, 0xEE, 0x00];
        assert_eq!(Acknowledgement::parse(&b).map(|a| a.control), Ok(control));
    }
    assert_eq!(Acknowledgement::parse(&[4, 0xFF, 0xFF, 0xFF, 1, 0, 0xEE, 0]), Err(Error::Malformed));
    assert_eq!(Acknowledgement::parse(&[1, 0xFF, 0xFF, 0xFF, 1, 0, 0xEE]), Err(Error::Length));
}

#[test]
fn fixed_lengths_are_enforced() {
    for len in [0usize, 3, 7] {
        let b = [0u8; 8];
        let d = &b[..len];
        assert_eq!(AddressClaimed::parse(d), Err(Error::Length));
        assert_eq!(CamRequest::parse(d), Err(Error::Length));
        assert_eq!(CamResponse::parse(d), Err(Error::Length));
        assert_eq!(Epos::parse(d), Err(Error::Length));
        assert_eq!(Espd::parse(d), Err(Error::Length));
        assert_eq!(ProprietaryB::parse(d), Err(Error::Length));
        assert_eq!(Emcy::parse(d), Err(Error::Length));
    }
}

#[test]
fn cam_commands_other_than_expedited_are_refused() {
    // Segmented download initiate (21h), download segment (00h), block (C0h, A0h), abort from
    // the client (80h): no expedited read or write.
    for cmd in [0x21, 0x20, 0x00, 0x10, 0x60, 0x80, 0xA0, 0xC0, 0xE0] {
        assert_eq!(CamRequest::parse(&[cmd, 0, 0x10, 0, 0, 0, 0, 0]), Err(Error::Malformed), "{cmd:02X}");
    }
    // 27h (3 bytes) and 22h (size not indicated) are CiA 301 expedited downloads.
    assert_eq!(
        CamRequest::parse(&[0x27, 0, 0x20, 1, 1, 2, 3, 4]),
        Ok(CamRequest::Write { index: 0x2000, sub: 1, value: 0x03_0201, len: Some(3) })
    );
    let no_size = CamRequest::Write { index: 0x2000, sub: 1, value: 0x0403_0201, len: None };
    assert_eq!(CamRequest::parse(&[0x22, 0, 0x20, 1, 1, 2, 3, 4]), Ok(no_size));
    assert_eq!(no_size.emit(), [0x22, 0, 0x20, 1, 1, 2, 3, 4]);
    // Responses: segmented upload (41h), upload without size (42h), segments.
    for cmd in [0x41, 0x42, 0x00, 0x20, 0x40, 0x61, 0xC0] {
        assert_eq!(CamResponse::parse(&[cmd, 0, 0x10, 0, 0, 0, 0, 0]), Err(Error::Malformed), "{cmd:02X}");
    }
    // A 1-byte read value drops the bytes past it, on emit and on parse.
    let r = CamResponse::Read { index: 1, sub: 2, value: 0x1234_56EF, len: 1 };
    assert_eq!(r.emit(), [0x4F, 1, 0, 2, 0xEF, 0, 0, 0]);
    assert_eq!(
        CamResponse::parse(&[0x4F, 1, 0, 2, 0xEF, 0x55, 0x55, 0x55]),
        Ok(CamResponse::Read { index: 1, sub: 2, value: 0xEF, len: 1 })
    );
}

#[test]
fn messages_are_classified_by_group() {
    let parse = |id: u32, data: &[u8]| Message::parse(&Frame::new(CanId::Ext(id), data)).map(|m| m.payload);
    let ff = [0xFF; 8];
    assert_eq!(parse(0x18EA_EF00, &[0x5F, 0xFC, 0x00]), Ok(Payload::Request(Request { pgn: Pgn::EPOS })));
    assert_eq!(
        parse(0x18E8_FFEF, &[1, 0xFF, 0xFF, 0xFF, 0, 0x00, 0xFF, 0x00]),
        Ok(Payload::Acknowledgement(Acknowledgement::nack(Pgn::new(0xFF00).unwrap(), Address(0))))
    );
    let name = AddressClaimed { name: Name::from_raw(0xB000_8E00_8E20_0001) };
    assert_eq!(parse(0x18EE_FFEF, &name.emit()), Ok(Payload::AddressClaimed(name)));
    assert_eq!(parse(0x18EE_FFFE, &name.emit()), Ok(Payload::CannotClaim(name)));
    assert_eq!(
        parse(0x1C06_EF00, &[0x40, 0x03, 0x60, 0, 0, 0, 0, 0]),
        Ok(Payload::Cam21(CamRequest::Read { index: 0x6003, sub: 0 }))
    );
    assert_eq!(
        parse(0x1C05_00EF, &[0x60, 0x00, 0x30, 3, 0, 0, 0, 0]),
        Ok(Payload::Cam11(CamResponse::Written { index: 0x3000, sub: 3 }))
    );
    assert_eq!(parse(0x0CFC_5FEF, &[1, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]), Ok(Payload::Epos(Epos { position: 1 })));
    assert_eq!(parse(0x0CFC_61EF, &ff), Ok(Payload::Espd(Espd { speed: -1 })));
    assert_eq!(
        parse(0x18FF_AAEF, &[1, 0, 0, 0, 2, 0, 0, 0]),
        Ok(Payload::ProprietaryB(ProprietaryB { position: 1, speed: 2 }))
    );
    assert_eq!(
        parse(0x04FC_68EF, &[0x20, 0x81, 0x11, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]),
        Ok(Payload::Emcy(Emcy { code: 0x8120, register: 0x11 }))
    );
    assert_eq!(parse(0x18FE_EE00, &ff), Ok(Payload::Other));
    // A known group with bytes that do not fit, and frames that are not J1939.
    assert_eq!(parse(0x0CFC_5FEF, &[1, 2, 3, 4]), Err(Error::Length));
    assert_eq!(parse(0x1C06_EF00, &[0xC0, 0, 0, 0, 0, 0, 0, 0]), Err(Error::Malformed));
    assert_eq!(Message::parse(&Frame::std(0x18F, &ff)), Err(Error::Malformed));
    // EDP set: not the device's group.
    assert_eq!(parse(0x0EFC_5FEF, &ff), Ok(Payload::Other));
}

mod properties {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2048, ..ProptestConfig::default() })]

        /// No input panics a parser, and whatever a parser accepts emits back to bytes that
        /// parse to the same value.
        #[test]
        fn parsers_never_panic(data in proptest::collection::vec(any::<u8>(), 0..=8), raw in any::<u32>(), rtr in any::<bool>(), ext in any::<bool>()) {
            if let Ok(r) = Request::parse(&data) { prop_assert_eq!(Request::parse(&r.emit()), Ok(r)); }
            if let Ok(a) = Acknowledgement::parse(&data) { prop_assert_eq!(Acknowledgement::parse(&a.emit()), Ok(a)); }
            if let Ok(c) = AddressClaimed::parse(&data) { prop_assert_eq!(&c.emit()[..], &data[..]); }
            if let Ok(c) = CamRequest::parse(&data) { prop_assert_eq!(CamRequest::parse(&c.emit()), Ok(c)); }
            if let Ok(c) = CamResponse::parse(&data) { prop_assert_eq!(CamResponse::parse(&c.emit()), Ok(c)); }
            if let Ok(e) = Epos::parse(&data) { prop_assert_eq!(Epos::parse(&e.emit()), Ok(e)); }
            if let Ok(e) = Espd::parse(&data) { prop_assert_eq!(Espd::parse(&e.emit()), Ok(e)); }
            if let Ok(p) = ProprietaryB::parse(&data) { prop_assert_eq!(ProprietaryB::parse(&p.emit()), Ok(p)); }
            if let Ok(e) = Emcy::parse(&data) { prop_assert_eq!(Emcy::parse(&e.emit()), Ok(e)); }
            let _ = Pgn::new(raw);
            let _ = Message::parse(&Frame::new(CanId::Ext(raw & 0x1FFF_FFFF), &data));
            let id = if ext { CanId::Ext(raw) } else { CanId::Std(raw as u16) };
            let frame = if rtr { Frame::remote(id, data.len() as u8) } else { Frame::new(id, &data) };
            if let Ok(i) = Identifier::from_frame(&frame) {
                prop_assert_eq!(CanId::Ext(i.emit()), frame.id);
            }
        }

        /// Frames of every known group, with any priority, addresses and bytes, parse or fail
        /// without panicking, and a parsed message keeps the frame's identifier.
        #[test]
        fn known_groups_never_panic(
            group in prop::sample::select(vec![0xEAu32 << 8, 0xE8 << 8, 0xEE << 8, 0x05 << 8, 0x06 << 8, 0xFC5F, 0xFC61, 0xFFAA, 0xFC68]),
            prio in 0u32..8, ps in any::<u8>(), sa in any::<u8>(),
            data in proptest::collection::vec(any::<u8>(), 0..=8),
        ) {
            let raw = prio << 26 | group << 8 | if group >> 8 < 240 { (ps as u32) << 8 } else { 0 } | sa as u32;
            let frame = Frame::new(CanId::Ext(raw), &data);
            if let Ok(m) = Message::parse(&frame) {
                prop_assert_eq!(m.id.emit(), raw);
                prop_assert!(m.payload != Payload::Other);
            }
        }

        /// Every 29-bit identifier parses, and emits back unchanged.
        #[test]
        fn identifiers_round_trip(raw in 0u32..=0x1FFF_FFFF) {
            let id = Identifier::parse(raw).unwrap();
            prop_assert_eq!(id.emit(), raw);
            prop_assert_eq!(id.destination().is_some(), id.pgn().is_pdu1());
            prop_assert_eq!(Pgn::new(id.pgn().raw()), Some(id.pgn()));
        }

        /// Every 64-bit value is a NAME whose fields build it again.
        #[test]
        fn names_round_trip(raw in any::<u64>()) {
            let n = Name::from_raw(raw);
            prop_assert_eq!(Name::from_fields(&n.fields()), Ok(n));
            prop_assert_eq!(Name::from_le_bytes(n.to_le_bytes()), n);
        }
    }
}

/// The frames `dbc/WV58MR.vectors.json` holds: emitted by this module, decoded by the Python
/// suite with cantools through `dbc/WV58MR.dbc`, so the DBC and the wire formats cannot drift
/// apart. Regenerate with `UPDATE_DBC=1 cargo test -p od-core --lib dbc_vectors`.
#[test]
fn dbc_vectors_are_current() {
    extern crate std;
    use std::format;
    use std::string::String;

    fn hex(f: &Frame) -> String {
        f.payload().iter().map(|b| format!("{b:02x}")).collect()
    }
    let mut out = String::from("[\n");
    let mut add = |message: &str, f: Frame, signals: String| {
        let CanId::Ext(raw) = f.id else { panic!("J1939 frames are extended") };
        if out.len() > 2 {
            out.push_str(",\n");
        }
        out.push_str(&format!(
            "  {{\"message\": \"{message}\", \"id\": {raw}, \"data\": \"{}\", \"signals\": {{{signals}}}}}",
            hex(&f)
        ));
    };
    let pdu2 = |p: u8, pgn: Pgn, sa: u8| Identifier::pdu2(prio(p), pgn, Address(sa)).unwrap();
    for (p, sa, position) in [(3, 0xEF, 0x12345u32), (2, 0xEF, 67_108_863), (3, 0x80, 0)] {
        let f = pdu2(p, Pgn::EPOS, sa).frame(&Epos { position }.emit());
        add("EPOS", f, format!("\"PositionValue\": {position}"));
    }
    for speed in [100i16, -2, -32768, 32767, 0] {
        let f = pdu2(3, Pgn::ESPD, 0xEF).frame(&Espd { speed }.emit());
        add("ESPD", f, format!("\"SpeedValue\": {speed}"));
    }
    for (position, speed) in [(0x12345u32, 100i16), (5, -300)] {
        let f = pdu2(6, Pgn::PROPRIETARY_B, 0xEF).frame(&ProprietaryB { position, speed }.emit());
        add("ProprietaryB", f, format!("\"PositionValue\": {position}, \"SpeedValue\": {speed}"));
    }
    for (code, register) in [(0xFF05u16, 0x81u8), (0x8120, 0x11), (0x8140, 0x11), (0xFF16, 0x81), (0, 0)] {
        let f = pdu2(1, Pgn::EMCY, 0xEF).frame(&Emcy { code, register }.emit());
        add("EMCY", f, format!("\"ErrorCode\": {code}, \"ErrorRegister\": {register}"));
    }
    for (id, sa) in [(0x12_3456u32, 0xEF), (1, 0x80), (0x1F_FFFF, 0xFE)] {
        let name = Name::from_fields(&wv58mr_name(id)).unwrap();
        let f = AddressClaimed { name }.frame(Address(sa));
        let n = name.fields();
        add(
            "AddressClaimed",
            f,
            format!(
                "\"IdentityNumber\": {}, \"ManufacturerCode\": {}, \"ECUInstance\": {}, \"FunctionInstance\": {}, \
                 \"Function\": {}, \"Reserved\": {}, \"VehicleSystem\": {}, \"VehicleSystemInstance\": {}, \
                 \"IndustryGroup\": {}, \"ArbitraryAddressCapable\": {}",
                n.identity_number,
                n.manufacturer_code,
                n.ecu_instance,
                n.function_instance,
                n.function,
                n.reserved as u8,
                n.vehicle_system,
                n.vehicle_system_instance,
                n.industry_group,
                n.arbitrary_address_capable as u8
            ),
        );
    }
    out.push_str("\n]\n");
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../dbc/WV58MR.vectors.json");
    if std::env::var_os("UPDATE_DBC").is_some() {
        std::fs::write(&path, &out).unwrap();
    }
    let stored = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(stored == out, "{} is stale: UPDATE_DBC=1 cargo test -p od-core --lib dbc_vectors", path.display());
}
