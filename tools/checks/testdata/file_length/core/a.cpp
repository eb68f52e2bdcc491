// fixture: 7 lines
int a() {
  return 1;
}

// end
// of a
