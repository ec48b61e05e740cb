//! The text of exported files, pinned: one program of each language (RAPID, KRL, FANUC TP)
//! imported into a cell, and a program taught with joints, each exported over REST in all three
//! formats. A change to what the exporter writes, to the motion class an import stores or to
//! the configuration written for taught joints shows here as a difference, file by file.

use serde_json::{Value, json};

use crate::helpers::*;

const RAPID: &str = "MODULE Pinned
  CONST robtarget pA:=[[400,0,500],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pB:=[[450,50,480],[0,0.7071068,0.7071068,0],[0,-1,2,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pC:=[[500,0,480],[0,0,1,0],[-1,0,0,4],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pD:=[[450,-50,480],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveJ pA, v1000, z50, tool0;
    MoveL pB, v200, fine, tool0\\WObj:=wobj1;
    MoveC pC, pD, v100, z10, tool0;
    TriggJ pA, v500, z10, trigg1, tool0;
    CapC pB, pC, v100, cd, wd, mt, tool0;
    SearchL di1, pHit, pD, v100, tool0;
    SpotJ pB, vmax, gun1, tool0;
    ArcLStart Offs(pA,0,0,50), v100, sm, wd, fine, tool0;
  ENDPROC
  PROC second()
    MoveL pA, v100, z1, tool0;
    MoveL [[420,10,470],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tool0;
    MoveL pD, v100, fine, tool0;
  ENDPROC
ENDMODULE
";

const KRL_SRC: &str = "DEF pinned()
  PTP xHome
  LIN xP1
  CIRC xP2, xP3
  LIN {X 410,Y 10,Z 490,A 0,B 90,C 0}
  SPTP xP1
  LIN_REL {X 0,Y 0,Z 20}
  SLIN xP3
END
";

const KRL_DAT: &str = "DEFDAT pinned
  DECL E6POS xHome={X 400,Y 0,Z 600,A 0,B 90,C 0,S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}
  DECL E6POS xP1={X 450,Y 0,Z 500,A 180,B 0,C 180,S 6,T 10}
  DECL FRAME xP2={X 470,Y 20,Z 500,A 180,B 0,C 180}
  DECL POS xP3={X 490,Y 0,Z 500,A 180,B 0,C 180,S 2}
ENDDAT
";

const FANUC_A: &str = "/PROG  PICK
/ATTR
OWNER = MNEDITOR;
/MN
   1:J P[1] 100% FINE    ;
   2:L P[2:approach] 500mm/sec CNT50    ;
   3:C P[3]    
    :  P[4] 100mm/sec FINE    ;
   4:A P[2] 100mm/sec CNT100 ;
   5:L P[1] 200mm/sec FINE ;
/POS
P[1]{
   GP1:
\tUF : 1, UT : 1,\t\tCONFIG : 'F U T, 0, 1, 0',
\tX =  400.000  mm,\tY =  -.500  mm,\tZ =   500  mm,
\tW =    180.000 deg,\tP =    0 deg,\tR =   90.000 deg
};
P[2:\"approach\"]{
   GP1:
\tUF : 1, UT : 1,\t\tCONFIG : 'N U T, 0, 0, 0',
\tX =  450  mm,\tY =  20  mm,\tZ =   480  mm,
\tW =    180 deg,\tP =    10 deg,\tR =   0 deg
};
P[3]{
   GP1:
\tUF : 1, UT : 1,
\tX =  470  mm,\tY =  40  mm,\tZ =   480  mm,
\tW =    180 deg,\tP =    0 deg,\tR =   0 deg
};
P[4]{
   GP1:
\tUF : 1, UT : 1,\t\tCONFIG : 'N D B, -1, 0, 1',
\tX =  490  mm,\tY =  20  mm,\tZ =   480  mm,
\tW =    180 deg,\tP =    0 deg,\tR =   -45 deg
};
/END
";

const FANUC_B: &str = "/PROG  PLACE
/MN
   1:J P[1] 50% FINE ;
   2:L P[2] 100mm/sec FINE ;
/POS
P[1]{
   GP1:
\tUF : 0, UT : 1,
\tX =  300  mm,\tY =  100  mm,\tZ =   400  mm,
\tW =    180 deg,\tP =    0 deg,\tR =   0 deg
};
P[2]{
   GP1:
\tUF : 0, UT : 1,
\tX =  300  mm,\tY =  100  mm,\tZ =   350  mm,
\tW =    180 deg,\tP =    0 deg,\tR =   0 deg
};
/END
";

/// Every exported file of every program in every format, as one text.
async fn exported(app: &TestApp, programs: &[(String, i64)]) -> String {
    let mut out = String::new();
    for (name, id) in programs {
        for format in ["rapid", "krl", "fanuc"] {
            let answer = app
                .get_ok(&format!("/v1/programs/{id}/export?format={format}"))
                .await;
            out.push_str(&format!("=== {name} as {format}\n"));
            for f in answer["files"].as_array().expect("files") {
                out.push_str(&format!("--- {}\n", f["file_name"].as_str().expect("name")));
                out.push_str(f["text"].as_str().expect("text"));
            }
            out.push_str(&format!("warnings: {}\n", answer["warnings"]));
            out.push_str(&format!(
                "unreachable: {}\n",
                answer["unreachable"].as_array().map_or(0, Vec::len)
            ));
        }
    }
    out
}

#[tokio::test]
async fn exported_files_of_one_program_of_each_language_are_pinned() {
    let app = spawn_app().await;
    let cell = app.create_cell("pinned").await;
    let imported = app
        .import(
            cell,
            &json!({ "files": [
                { "name": "Pinned.mod", "content": RAPID },
                { "name": "krl/pinned.src", "content": KRL_SRC },
                { "name": "krl/pinned.dat", "content": KRL_DAT },
                { "name": "cell/job/PICK.LS", "content": FANUC_A },
                { "name": "cell/job/PLACE.LS", "content": FANUC_B },
            ], "learn": false }),
        )
        .await;
    let mut programs: Vec<(String, i64)> = imported["programs"]
        .as_array()
        .expect("programs")
        .iter()
        .map(|p: &Value| {
            (
                format!(
                    "{} ({})",
                    p["program"]["name"].as_str().expect("name"),
                    p["language"].as_str().expect("language")
                ),
                p["program"]["id"].as_i64().expect("id"),
            )
        })
        .collect();
    assert_eq!(programs.len(), 3, "{imported}");
    // A program taught with joints: its targets carry the joints' configuration.
    let taught = app.create_program(cell, "Taught").await;
    let r = app.create_routine(taught).await;
    let robot =
        nextpose::kinematics::load_robot(&nextpose::kinematics::bundled_robots_dir(), "abb_irb140")
            .expect("robot");
    for (k, q) in [
        [0.3, 0.2, 0.1, 0.4, -0.6, 0.2],
        [-0.4, 0.3, 0.2, -2.0, 0.7, 3.5],
        [0.1, -0.2, 0.4, 0.0, 0.5, 0.0],
    ]
    .into_iter()
    .enumerate()
    {
        let v = robot.fk(&q).values();
        let pose =
            json!({ "x": v.x, "y": v.y, "z": v.z, "qw": v.qw, "qx": v.qx, "qy": v.qy, "qz": v.qz });
        let motion = ["joint", "linear", "circular"][k];
        app.post_ok(
            &format!("/v1/routines/{r}/waypoints"),
            &json!({ "pose": pose, "joints": q, "name": format!("t{k}"), "motion": motion }),
            reqwest::StatusCode::CREATED,
        )
        .await;
    }
    app.finish(r).await;
    programs.push(("Taught".into(), taught));
    let got = exported(&app, &programs).await;
    if let Ok(path) = std::env::var("NEXTPOSE_PINNED_EXPORT_OUT") {
        std::fs::write(path, &got).expect("written");
    }
    assert_eq!(got, PINNED, "the exported text changed");
}

/// What the exporter wrote for these programs before the program model was one type (issue
/// 47): the same text is written now.
const PINNED: &str = r##"=== Pinned (rapid) as rapid
--- Pinned.mod
MODULE Pinned
    ! Exported by nextpose: positions in mm in work object wobj0, orientations as quaternions.
    CONST robtarget pA:=[[400.000,0.000,500.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pB:=[[450.000,50.000,480.000],[0.00000000,0.70710678,0.70710678,0.00000000],[0,0,1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pC:=[[500.000,0.000,480.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pD:=[[450.000,-50.000,480.000],[0.00000000,0.00000000,1.00000000,0.00000000],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget Offs_pA_0_0_50:=[[400.000,0.000,550.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget literal_L18:=[[420.000,10.000,470.000],[1.00000000,0.00000000,0.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    PROC main()
        MoveJ pA, v100, z10, tool0\WObj:=wobj0;
        MoveL pB, v100, z10, tool0\WObj:=wobj0;
        MoveC pC, pD, v100, z10, tool0\WObj:=wobj0;
        MoveL pA, v100, z10, tool0\WObj:=wobj0;
        MoveL pB, v100, z10, tool0\WObj:=wobj0;
        MoveL pC, v100, z10, tool0\WObj:=wobj0;
        MoveL pD, v100, z10, tool0\WObj:=wobj0;
        MoveL pB, v100, z10, tool0\WObj:=wobj0;
        MoveL Offs_pA_0_0_50, v100, z10, tool0\WObj:=wobj0;
    ENDPROC

    PROC second()
        MoveL pA, v100, z10, tool0\WObj:=wobj0;
        ! literal_L18: out of the arm's reach
        MoveL literal_L18, v100, z10, tool0\WObj:=wobj0;
        MoveL pD, v100, z10, tool0\WObj:=wobj0;
    ENDPROC
ENDMODULE
warnings: ["main: waypoint 10 \"Offs(pA,0,0,50)\" renamed Offs_pA_0_0_50","second: waypoint 2 \"literal@L18\" renamed literal_L18","second: waypoint 2 (literal_L18) is out of the arm's reach","1 waypoint(s) without an arm configuration: the default one is written"]
unreachable: 1
=== Pinned (rapid) as krl
--- Pinned.src
&ACCESS RVP
&REL 1
DEF Pinned( )
  main( )
  second( )
END

DEF main( )
;FOLD settings (exported by nextpose)
  BAS(#INITMOV, 0)
  $BASE = $NULLFRAME
  $TOOL = $NULLFRAME
  $VEL.CP = 0.1000
  $APO.CDIS = 10.000
  $APO.CPTP = 10
;ENDFOLD
  PTP pA C_PTP
  LIN pB C_DIS
  CIRC pC, pD C_DIS
  LIN pA C_DIS
  LIN pB C_DIS
  LIN pC C_DIS
  LIN pD C_DIS
  LIN pB C_DIS
  LIN Offs_pA_0_0_50 C_DIS
END

DEF second( )
;FOLD settings (exported by nextpose)
  BAS(#INITMOV, 0)
  $BASE = $NULLFRAME
  $TOOL = $NULLFRAME
  $VEL.CP = 0.1000
  $APO.CDIS = 10.000
  $APO.CPTP = 10
;ENDFOLD
  LIN pA C_DIS
  ; literal_L18: out of the arm's reach
  LIN literal_L18 C_DIS
  LIN pD C_DIS
END

--- Pinned.dat
&ACCESS RVP
&REL 1
DEFDAT Pinned
; positions exported by nextpose: mm, A B C ZYX Euler angles in degrees
  DECL E6POS pA={X 400.000,Y 0.000,Z 500.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS pB={X 450.000,Y 50.000,Z 480.000,A 90.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS pC={X 500.000,Y 0.000,Z 480.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS pD={X 450.000,Y -50.000,Z 480.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 33,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS Offs_pA_0_0_50={X 400.000,Y 0.000,Z 550.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS literal_L18={X 420.000,Y 10.000,Z 470.000,A 0.0000,B 0.0000,C 0.0000,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
ENDDAT
warnings: ["main: waypoint 10 \"Offs(pA,0,0,50)\" renamed Offs_pA_0_0_50","second: waypoint 2 \"literal@L18\" renamed literal_L18","second: waypoint 2 (literal_L18) is out of the arm's reach","1 waypoint(s) without an arm configuration: the default one is written"]
unreachable: 1
=== Pinned (rapid) as fanuc
--- Pinned/MAIN.ls
/PROG  MAIN
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "nextpose export";
PROG_SIZE	= 0;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 11;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% CNT10    ;
   4:L P[2] 100mm/sec CNT10    ;
   5:C P[3]    
    :  P[4] 100mm/sec CNT10    ;
   6:L P[1] 100mm/sec CNT10    ;
   7:L P[2] 100mm/sec CNT10    ;
   8:L P[3] 100mm/sec CNT10    ;
   9:L P[4] 100mm/sec CNT10    ;
  10:L P[2] 100mm/sec CNT10    ;
  11:L P[5] 100mm/sec CNT10    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   400.000  mm,	Y =     0.000  mm,	Z =   500.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   450.000  mm,	Y =    50.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =    90.000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   500.000  mm,	Y =     0.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[4]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   450.000  mm,	Y =   -50.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[5]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   400.000  mm,	Y =     0.000  mm,	Z =   550.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
/END
--- Pinned/SECOND.ls
/PROG  SECOND
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "nextpose export";
PROG_SIZE	= 0;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 6;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:L P[1] 100mm/sec CNT10    ;
   4:  !P[2] OUT OF REACH ;
   5:L P[2] 100mm/sec CNT10    ;
   6:L P[3] 100mm/sec CNT10    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   400.000  mm,	Y =     0.000  mm,	Z =   500.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   420.000  mm,	Y =    10.000  mm,	Z =   470.000  mm,
	W =     0.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   450.000  mm,	Y =   -50.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
/END
warnings: ["routine 1 \"main\" renamed MAIN","routine 2 \"second\" renamed SECOND","MAIN: waypoint 1 \"pA\" renamed P[1]","MAIN: waypoint 2 \"pB\" renamed P[2]","MAIN: waypoint 3 \"pC\" renamed P[3]","MAIN: waypoint 4 \"pD\" renamed P[4]","MAIN: waypoint 5 \"pA\" renamed P[1]","MAIN: waypoint 6 \"pB\" renamed P[2]","MAIN: waypoint 7 \"pC\" renamed P[3]","MAIN: waypoint 8 \"pD\" renamed P[4]","MAIN: waypoint 9 \"pB\" renamed P[2]","MAIN: waypoint 10 \"Offs(pA,0,0,50)\" renamed P[5]","SECOND: waypoint 1 \"pA\" renamed P[1]","SECOND: waypoint 2 \"literal@L18\" renamed P[2]","SECOND: waypoint 3 \"pD\" renamed P[3]","SECOND: waypoint 2 (P[2]) is out of the arm's reach","1 waypoint(s) without an arm configuration: the default one is written"]
unreachable: 1
=== pinned (krl) as rapid
--- pinned.mod
MODULE pinned
    ! Exported by nextpose: positions in mm in work object wobj0, orientations as quaternions.
    CONST robtarget xHome:=[[400.000,0.000,600.000],[0.70710678,0.00000000,0.70710678,0.00000000],[0,0,0,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget xP1:=[[450.000,0.000,500.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget xP2:=[[470.000,20.000,500.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget xP3:=[[490.000,0.000,500.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget X_410_Y_10_Z_490_A_0_B_90_C_0:=[[410.000,10.000,490.000],[0.70710678,0.00000000,0.70710678,0.00000000],[0,0,-1,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget X_0_Y_0_Z_20:=[[450.000,0.000,520.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    PROC pinned_2()
        MoveJ xHome, v100, z10, tool0\WObj:=wobj0;
        MoveL xP1, v100, z10, tool0\WObj:=wobj0;
        MoveC xP2, xP3, v100, z10, tool0\WObj:=wobj0;
        MoveL X_410_Y_10_Z_490_A_0_B_90_C_0, v100, z10, tool0\WObj:=wobj0;
        MoveJ xP1, v100, z10, tool0\WObj:=wobj0;
        MoveL X_0_Y_0_Z_20, v100, z10, tool0\WObj:=wobj0;
        MoveL xP3, v100, z10, tool0\WObj:=wobj0;
    ENDPROC
ENDMODULE
warnings: ["routine 1 \"pinned\" renamed pinned_2","pinned_2: waypoint 5 \"{X 410,Y 10,Z 490,A 0,B 90,C 0}\" renamed X_410_Y_10_Z_490_A_0_B_90_C_0","pinned_2: waypoint 7 \"{X 0,Y 0,Z 20}\" renamed X_0_Y_0_Z_20"]
unreachable: 0
=== pinned (krl) as krl
--- pinned.src
&ACCESS RVP
&REL 1
DEF pinned( )
;FOLD settings (exported by nextpose)
  BAS(#INITMOV, 0)
  $BASE = $NULLFRAME
  $TOOL = $NULLFRAME
  $VEL.CP = 0.1000
  $APO.CDIS = 10.000
  $APO.CPTP = 10
;ENDFOLD
  PTP xHome C_PTP
  LIN xP1 C_DIS
  CIRC xP2, xP3 C_DIS
  LIN X_410_Y_10_Z_490_A_0_B_9 C_DIS
  PTP xP1 C_PTP
  LIN X_0_Y_0_Z_20 C_DIS
  LIN xP3 C_DIS
END

--- pinned.dat
&ACCESS RVP
&REL 1
DEFDAT pinned
; positions exported by nextpose: mm, A B C ZYX Euler angles in degrees
  DECL E6POS xHome={X 400.000,Y 0.000,Z 600.000,A 0.0000,B 90.0000,C 0.0000,S 6,T 18,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS xP1={X 450.000,Y 0.000,Z 500.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS xP2={X 470.000,Y 20.000,Z 500.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS xP3={X 490.000,Y 0.000,Z 500.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS X_410_Y_10_Z_490_A_0_B_9={X 410.000,Y 10.000,Z 490.000,A 0.0000,B 90.0000,C 0.0000,S 6,T 50,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS X_0_Y_0_Z_20={X 450.000,Y 0.000,Z 520.000,A 180.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
ENDDAT
warnings: ["pinned: waypoint 5 \"{X 410,Y 10,Z 490,A 0,B 90,C 0}\" renamed X_410_Y_10_Z_490_A_0_B_9","pinned: waypoint 7 \"{X 0,Y 0,Z 20}\" renamed X_0_Y_0_Z_20"]
unreachable: 0
=== pinned (krl) as fanuc
--- pinned/PINNED.ls
/PROG  PINNED
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "nextpose export";
PROG_SIZE	= 0;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 9;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% CNT10    ;
   4:L P[2] 100mm/sec CNT10    ;
   5:C P[3]    
    :  P[4] 100mm/sec CNT10    ;
   6:L P[5] 100mm/sec CNT10    ;
   7:J P[2] 100% CNT10    ;
   8:L P[6] 100mm/sec CNT10    ;
   9:L P[4] 100mm/sec CNT10    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U T, 0, 0, 0',
	X =   400.000  mm,	Y =     0.000  mm,	Z =   600.000  mm,
	W =     0.000 deg,	P =    90.000 deg,	R =     0.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   450.000  mm,	Y =     0.000  mm,	Z =   500.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   470.000  mm,	Y =    20.000  mm,	Z =   500.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[4]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   490.000  mm,	Y =     0.000  mm,	Z =   500.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
P[5]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U T, 0, 0, 0',
	X =   410.000  mm,	Y =    10.000  mm,	Z =   490.000  mm,
	W =     0.000 deg,	P =    90.000 deg,	R =     0.000 deg
};
P[6]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   450.000  mm,	Y =     0.000  mm,	Z =   520.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   180.000 deg
};
/END
warnings: ["routine 1 \"pinned\" renamed PINNED","PINNED: waypoint 1 \"xHome\" renamed P[1]","PINNED: waypoint 2 \"xP1\" renamed P[2]","PINNED: waypoint 3 \"xP2\" renamed P[3]","PINNED: waypoint 4 \"xP3\" renamed P[4]","PINNED: waypoint 5 \"{X 410,Y 10,Z 490,A 0,B 90,C 0}\" renamed P[5]","PINNED: waypoint 6 \"xP1\" renamed P[2]","PINNED: waypoint 7 \"{X 0,Y 0,Z 20}\" renamed P[6]","PINNED: waypoint 8 \"xP3\" renamed P[4]"]
unreachable: 0
=== job (fanuc) as rapid
--- job.mod
MODULE job
    ! Exported by nextpose: positions in mm in work object wobj0, orientations as quaternions.
    CONST robtarget P_1:=[[400.000,-0.500,500.000],[0.00000000,0.70710678,0.70710678,0.00000000],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget P_2:=[[450.000,20.000,480.000],[0.00000000,0.99619470,0.00000000,-0.08715574],[0,0,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget P_3:=[[470.000,40.000,480.000],[0.00000000,1.00000000,0.00000000,0.00000000],[0,0,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget P_4:=[[490.000,20.000,480.000],[0.00000000,0.92387953,-0.38268343,0.00000000],[0,0,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget P_1_2:=[[300.000,100.000,400.000],[0.00000000,1.00000000,0.00000000,0.00000000],[-2,0,0,7],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget P_2_2:=[[300.000,100.000,350.000],[0.00000000,1.00000000,0.00000000,0.00000000],[-2,0,0,7],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    PROC PICK()
        MoveJ P_1, v100, z10, tool0\WObj:=wobj0;
        MoveL P_2, v100, z10, tool0\WObj:=wobj0;
        MoveC P_3, P_4, v100, z10, tool0\WObj:=wobj0;
        MoveL P_2, v100, z10, tool0\WObj:=wobj0;
        MoveL P_1, v100, z10, tool0\WObj:=wobj0;
    ENDPROC

    PROC PLACE()
        MoveJ P_1_2, v100, z10, tool0\WObj:=wobj0;
        MoveL P_2_2, v100, z10, tool0\WObj:=wobj0;
    ENDPROC
ENDMODULE
warnings: ["PICK: waypoint 1 \"P[1]\" renamed P_1","PICK: waypoint 2 \"P[2]\" renamed P_2","PICK: waypoint 3 \"P[3]\" renamed P_3","PICK: waypoint 4 \"P[4]\" renamed P_4","PICK: waypoint 5 \"P[2]\" renamed P_2","PICK: waypoint 6 \"P[1]\" renamed P_1","PLACE: waypoint 1 \"P[1]\" renamed P_1_2","PLACE: waypoint 2 \"P[2]\" renamed P_2_2"]
unreachable: 0
=== job (fanuc) as krl
--- job.src
&ACCESS RVP
&REL 1
DEF job( )
  PICK( )
  PLACE( )
END

DEF PICK( )
;FOLD settings (exported by nextpose)
  BAS(#INITMOV, 0)
  $BASE = $NULLFRAME
  $TOOL = $NULLFRAME
  $VEL.CP = 0.1000
  $APO.CDIS = 10.000
  $APO.CPTP = 10
;ENDFOLD
  PTP P_1 C_PTP
  LIN P_2 C_DIS
  CIRC P_3, P_4 C_DIS
  LIN P_2 C_DIS
  LIN P_1 C_DIS
END

DEF PLACE( )
;FOLD settings (exported by nextpose)
  BAS(#INITMOV, 0)
  $BASE = $NULLFRAME
  $TOOL = $NULLFRAME
  $VEL.CP = 0.1000
  $APO.CDIS = 10.000
  $APO.CPTP = 10
;ENDFOLD
  PTP P_1_2 C_PTP
  LIN P_2_2 C_DIS
END

--- job.dat
&ACCESS RVP
&REL 1
DEFDAT job
; positions exported by nextpose: mm, A B C ZYX Euler angles in degrees
  DECL E6POS P_1={X 400.000,Y -0.500,Z 500.000,A 90.0000,B 0.0000,C 180.0000,S 2,T 3,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS P_2={X 450.000,Y 20.000,Z 480.000,A 0.0000,B 10.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS P_3={X 470.000,Y 40.000,Z 480.000,A 0.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS P_4={X 490.000,Y 20.000,Z 480.000,A -45.0000,B 0.0000,C 180.0000,S 2,T 0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS P_1_2={X 300.000,Y 100.000,Z 400.000,A 0.0000,B 0.0000,C 180.0000,S 5,T 23,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS P_2_2={X 300.000,Y 100.000,Z 350.000,A 0.0000,B 0.0000,C 180.0000,S 5,T 23,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
ENDDAT
warnings: ["PICK: waypoint 1 \"P[1]\" renamed P_1","PICK: waypoint 2 \"P[2]\" renamed P_2","PICK: waypoint 3 \"P[3]\" renamed P_3","PICK: waypoint 4 \"P[4]\" renamed P_4","PICK: waypoint 5 \"P[2]\" renamed P_2","PICK: waypoint 6 \"P[1]\" renamed P_1","PLACE: waypoint 1 \"P[1]\" renamed P_1_2","PLACE: waypoint 2 \"P[2]\" renamed P_2_2"]
unreachable: 0
=== job (fanuc) as fanuc
--- job/PICK.ls
/PROG  PICK
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "nextpose export";
PROG_SIZE	= 0;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 7;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% CNT10    ;
   4:L P[2] 100mm/sec CNT10    ;
   5:C P[3]    
    :  P[4] 100mm/sec CNT10    ;
   6:L P[2] 100mm/sec CNT10    ;
   7:L P[1] 100mm/sec CNT10    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   400.000  mm,	Y =    -0.500  mm,	Z =   500.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =    90.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 1',
	X =   450.000  mm,	Y =    20.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =    10.000 deg,	R =     0.000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 1',
	X =   470.000  mm,	Y =    40.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[4]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 1',
	X =   490.000  mm,	Y =    20.000  mm,	Z =   480.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   -45.000 deg
};
/END
--- job/PLACE.ls
/PROG  PLACE
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "nextpose export";
PROG_SIZE	= 0;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 4;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% CNT10    ;
   4:L P[2] 100mm/sec CNT10    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F D B, 0, 0, 0',
	X =   300.000  mm,	Y =   100.000  mm,	Z =   400.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F D B, 0, 0, 0',
	X =   300.000  mm,	Y =   100.000  mm,	Z =   350.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
/END
warnings: []
unreachable: 0
=== Taught as rapid
--- Taught.mod
MODULE Taught
    ! Exported by nextpose: positions in mm in work object wobj0, orientations as quaternions.
    CONST robtarget t0:=[[544.743,153.548,608.967],[0.74809268,0.15829363,0.59031670,0.25850855],[0,0,0,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget t1:=[[502.672,-253.866,505.197],[0.65336940,0.69048907,0.29821485,0.08603008],[-1,-2,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget t2:=[[418.518,41.992,587.455],[0.42124435,-0.04531622,0.90556904,0.02107979],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    PROC routine1()
        MoveJ t0, v100, z10, tool0\WObj:=wobj0;
        MoveL t1, v100, z10, tool0\WObj:=wobj0;
        MoveL t2, v100, z10, tool0\WObj:=wobj0;
    ENDPROC
ENDMODULE
warnings: ["routine1: circular waypoint 3 has no partner: moved to linearly"]
unreachable: 0
=== Taught as krl
--- Taught.src
&ACCESS RVP
&REL 1
DEF Taught( )
  routine1( )
END

DEF routine1( )
;FOLD settings (exported by nextpose)
  BAS(#INITMOV, 0)
  $BASE = $NULLFRAME
  $TOOL = $NULLFRAME
  $VEL.CP = 0.1000
  $APO.CDIS = 10.000
  $APO.CPTP = 10
;ENDFOLD
  PTP t0 C_PTP
  LIN t1 C_DIS
  LIN t2 C_DIS
END

--- Taught.dat
&ACCESS RVP
&REL 1
DEFDAT Taught
; positions exported by nextpose: mm, A B C ZYX Euler angles in degrees
  DECL E6POS t0={X 544.743,Y 153.548,Z 608.967,A 73.5485,B 53.2623,C 64.9843,S 6,T 16,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS t1={X 502.672,Y -253.866,Z 505.197,A 32.9979,B 15.7168,C 97.8464,S 2,T 9,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
  DECL E6POS t2={X 418.518,Y 41.992,Z 587.455,A -174.2704,B 49.8930,C 180.0000,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
ENDDAT
warnings: ["routine1: circular waypoint 3 has no partner: moved to linearly"]
unreachable: 0
=== Taught as fanuc
--- Taught/ROUTINE1.ls
/PROG  ROUTINE1
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "nextpose export";
PROG_SIZE	= 0;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 5;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% CNT10    ;
   4:L P[2] 100mm/sec CNT10    ;
   5:L P[3] 100mm/sec CNT10    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U T, 0, 0, 0',
	X =   544.743  mm,	Y =   153.548  mm,	Z =   608.967  mm,
	W =    64.984 deg,	P =    53.262 deg,	R =    73.548 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 1',
	X =   502.672  mm,	Y =  -253.866  mm,	Z =   505.197  mm,
	W =    97.846 deg,	P =    15.717 deg,	R =    32.998 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   418.518  mm,	Y =    41.992  mm,	Z =   587.455  mm,
	W =   180.000 deg,	P =    49.893 deg,	R =  -174.270 deg
};
/END
warnings: ["routine 1 \"routine1\" renamed ROUTINE1","ROUTINE1: waypoint 1 \"t0\" renamed P[1]","ROUTINE1: waypoint 2 \"t1\" renamed P[2]","ROUTINE1: waypoint 3 \"t2\" renamed P[3]","routine1: circular waypoint 3 has no partner: moved to linearly"]
unreachable: 0
"##;
