// fixture: what the glossary fixture names
namespace xx {
struct Here {};
}  // namespace xx
int pwm_us = 0;
