"""The best designs RoboGrammar reports, as rule sequences: pure data, derived by `grammar.derivation`."""

REFERENCE_DESIGNS = {
    "robogrammar_flat": "0,12,7,1,12,3,10,1,3,1,12,12,1,3,10,2,16,8,1,3,12,4,1,3,2,12,18,9,18,8,5,5,1,12,6,3",
    "robogrammar_ridged": "0,7,1,13,1,2,16,12,13,6,4,19,4,17,5,3,2,16,4,5,18,9,8,9,9,8",
}
