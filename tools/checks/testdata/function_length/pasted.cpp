// fixture: a function of 10 lines that pastes a 75-line fragment: 84 lines as the check counts.
namespace fixture {

int pasted(int total) {
  total += 0;
#include "pasted_steps.inc"
  total += 100;
  total += 101;
  total += 102;
  total += 103;
  total += 104;
  return total;
}

}  // namespace fixture
