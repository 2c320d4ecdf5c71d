/PROG  PICK_PLACE
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "rworld";
PROG_SIZE	= 0;
CREATE		= DATE 00-01-01  TIME 00:00:00;
MODIFIED	= DATE 00-01-01  TIME 00:00:00;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 122;
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
   1:  !pick_place: device 'puma', from  ;
   2:  !workcells/puma560/programs/pick_ ;
   3:  !place.yaml ;
   4:  !written by 'rworld export ;
   5:  !program': targets resolved with ;
   6:  !the cell's current pose files ;
   7:  !outputs: gripper DO[1] (ON = ;
   8:  !closed), tool changer DO[2] (ON ;
   9:  != locked), searches skip on ;
  10:  !DI[1] ;
  11:  !'PICK_PLACE' is program ;
  12:  !'pick_place' ;
  13:  !tool data in the flange frame: ;
  14:  !the last link's (no controller ;
  15:  !flange given) ;
  16:  !targets in the base frame: ;
  17:  !'puma' (no controller base ;
  18:  !given) ;
  19:  !axis values: the cell's joint ;
  20:  !values ;
  21:  !CONFIG: F when J5 > 0, U elbow ;
  22:  !up, T wrist centre in front of ;
  23:  !J1, then the turns of J4, J5, J6 ;
  24:  !PR[90] carries tool and user ;
  25:  !frame values ;
  26:  !UFRAME 0: the world frame (the ;
  27:  !robot's base) ;
  28:  UFRAME_NUM=0 ;
  29:  !load on the flange: none ;
  30:  !kg, cm, kgf cm s^2, flange axes ;
  31:  $PLST_GRP1[1].$PAYLOAD=0.000000 ;
  32:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
  33:  $PLST_GRP1[1].$PAYLOAD_Y=0.000000 ;
  34:  $PLST_GRP1[1].$PAYLOAD_Z=0.000000 ;
  35:  $PLST_GRP1[1].$PAYLOAD_IX=0.000000 ;
  36:  $PLST_GRP1[1].$PAYLOAD_IY=0.000000 ;
  37:  $PLST_GRP1[1].$PAYLOAD_IZ=0.000000 ;
  38:  PAYLOAD[1] ;
  39:  !UTOOL[1] is puma.tool ;
  40:  PR[90]=LPOS-LPOS ;
  41:  PR[90,1]=0.000000 ;
  42:  PR[90,2]=0.000000 ;
  43:  PR[90,3]=0.000000 ;
  44:  PR[90,4]=0.000000 ;
  45:  PR[90,5]=0.000000 ;
  46:  PR[90,6]=0.000000 ;
  47:  UTOOL[1]=PR[90] ;
  48:  UTOOL_NUM=1 ;
  49:  !workcells/puma560/programs/pick_ ;
  50:  !place.yaml:9: move to ready ;
  51:J P[1] 100% FINE ;
  52:  !UTOOL[2] is puma.probe ;
  53:  PR[90]=LPOS-LPOS ;
  54:  PR[90,1]=0.000000 ;
  55:  PR[90,2]=0.000000 ;
  56:  PR[90,3]=100.000000 ;
  57:  PR[90,4]=0.000000 ;
  58:  PR[90,5]=0.000000 ;
  59:  PR[90,6]=0.000000 ;
  60:  UTOOL[2]=PR[90] ;
  61:  UTOOL_NUM=2 ;
  62:  !workcells/puma560/programs/pick_ ;
  63:  !place.yaml:10: move to ;
  64:  !workpiece.grasp ;
  65:J P[2] 100% FINE ;
  66:  !workcells/puma560/programs/pick_ ;
  67:  !place.yaml:11: move to ;
  68:  !workpiece.grasp (linear) ;
  69:L P[3] 125mm/sec FINE ;
  70:  !workcells/puma560/programs/pick_ ;
  71:  !place.yaml:12: grasp workpiece ;
  72:  DO[1]=ON ;
  73:  !load on the flange: workpiece ;
  74:  !1.2 kg ;
  75:  !kg, cm, kgf cm s^2, flange axes ;
  76:  $PLST_GRP1[1].$PAYLOAD=1.200000 ;
  77:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
  78:  $PLST_GRP1[1].$PAYLOAD_Y=0.000000 ;
  79:  $PLST_GRP1[1].$PAYLOAD_Z=12.500000 ;
  80:  $PLST_GRP1[1].$PAYLOAD_IX=0.012746 ;
  81:  $PLST_GRP1[1].$PAYLOAD_IY=0.022944 ;
  82:  $PLST_GRP1[1].$PAYLOAD_IZ=0.035690 ;
  83:  PAYLOAD[1] ;
  84:  !workcells/puma560/programs/pick_ ;
  85:  !place.yaml:13: move to ;
  86:  !table.drop ;
  87:J P[4] 100% FINE ;
  88:  !workcells/puma560/programs/pick_ ;
  89:  !place.yaml:14: move to ;
  90:  !table.drop (linear) ;
  91:L P[5] 125mm/sec FINE ;
  92:  !workcells/puma560/programs/pick_ ;
  93:  !place.yaml:15: place workpiece ;
  94:  !on table.top_center ;
  95:  DO[1]=OFF ;
  96:  !load on the flange: none ;
  97:  !kg, cm, kgf cm s^2, flange axes ;
  98:  $PLST_GRP1[1].$PAYLOAD=0.000000 ;
  99:  $PLST_GRP1[1].$PAYLOAD_X=0.000000 ;
 100:  $PLST_GRP1[1].$PAYLOAD_Y=0.000000 ;
 101:  $PLST_GRP1[1].$PAYLOAD_Z=0.000000 ;
 102:  $PLST_GRP1[1].$PAYLOAD_IX=0.000000 ;
 103:  $PLST_GRP1[1].$PAYLOAD_IY=0.000000 ;
 104:  $PLST_GRP1[1].$PAYLOAD_IZ=0.000000 ;
 105:  PAYLOAD[1] ;
 106:  !workcells/puma560/programs/pick_ ;
 107:  !place.yaml:16: move to ;
 108:  !table.drop (linear) ;
 109:L P[6] 250mm/sec FINE ;
 110:  !UTOOL[1] is puma.tool ;
 111:  PR[90]=LPOS-LPOS ;
 112:  PR[90,1]=0.000000 ;
 113:  PR[90,2]=0.000000 ;
 114:  PR[90,3]=0.000000 ;
 115:  PR[90,4]=0.000000 ;
 116:  PR[90,5]=0.000000 ;
 117:  PR[90,6]=0.000000 ;
 118:  UTOOL[1]=PR[90] ;
 119:  UTOOL_NUM=1 ;
 120:  !workcells/puma560/programs/pick_ ;
 121:  !place.yaml:17: move to home ;
 122:J P[7] 100% FINE ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 1,
	J1=    0.000000 deg,	J2=   45.000000 deg,	J3= -135.000000 deg,
	J4=    0.000000 deg,	J5=  -45.000000 deg,	J6=    0.000000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 2,
	J1=   32.159232 deg,	J2=   42.639714 deg,	J3= -176.595134 deg,
	J4=    0.000000 deg,	J5=  -46.044580 deg,	J6= -177.840768 deg
};
P[3]{
   GP1:
	UF : 0, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   599.999998  mm,	Y =   199.999999  mm,	Z =   450.000000  mm,
	W =   180.000000 deg,	P =     0.000000 deg,	R =    30.000000 deg
};
P[4]{
   GP1:
	UF : 0, UT : 2,
	J1=  -13.639703 deg,	J2=   38.906300 deg,	J3= -168.890974 deg,
	J4=    0.000000 deg,	J5=  -50.015326 deg,	J6= -193.639703 deg
};
P[5]{
   GP1:
	UF : 0, UT : 2,		CONFIG : 'N U T, 0, 0, -1',
	X =   599.999998  mm,	Y =  -300.000000  mm,	Z =   450.000000  mm,
	W =   180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[6]{
   GP1:
	UF : 0, UT : 2,		CONFIG : 'N U T, 0, 0, -1',
	X =   599.999998  mm,	Y =  -300.000000  mm,	Z =   550.000000  mm,
	W =   180.000000 deg,	P =     0.000000 deg,	R =     0.000000 deg
};
P[7]{
   GP1:
	UF : 0, UT : 1,
	J1=    0.000000 deg,	J2=   45.000000 deg,	J3= -180.000000 deg,
	J4=    0.000000 deg,	J5=   45.000000 deg,	J6=    0.000000 deg
};
/END
