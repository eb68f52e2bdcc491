// fixture: 3 lines
int b();
// end
