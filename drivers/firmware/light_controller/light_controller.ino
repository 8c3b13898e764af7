// matscan light controller, reference firmware (Arduino Uno / Nano, ATmega328P).
//
// Speaks protocol 1 of docs/light-protocol.md at 115200 8N1: switches
// flash0, flash1 and the backlight (PWM duty 0..255 through a logic-level
// MOSFET or an LED driver's PWM input), acknowledges every request with its
// sequence number, answers a repeated sequence number from memory (so host
// retries are idempotent) and switches every light off when no valid request
// arrived for HEARTBEAT_MS. Prints READY after every reset. The Rust state
// machine drivers/src/lights/board.rs behaves exactly like this sketch.

#include <string.h>
#include <stdlib.h>

static const char FIRMWARE[] = "uno-1.0";
static const unsigned PROTOCOL = 1;
static const unsigned long HEARTBEAT_MS = 2000;
static const uint8_t PIN_FLASH0 = 9;     // PWM pins (Timer1 / Timer2: no
static const uint8_t PIN_FLASH1 = 10;    // conflict with millis()).
static const uint8_t PIN_BACKLIGHT = 3;
static const uint8_t PINS[3] = {PIN_FLASH0, PIN_FLASH1, PIN_BACKLIGHT};
static const char *CODES[3] = {"F0", "F1", "BL"};
static const uint8_t MAX_LINE = 96;

static char line[MAX_LINE + 1];
static uint8_t line_len = 0;
static bool line_overflow = false;
static uint8_t duty[3] = {0, 0, 0};
static bool have_last = false;
static uint16_t last_seq = 0;
static char last_reply[MAX_LINE + 1];
static unsigned long last_request_ms = 0;
static bool heartbeat_armed = false;

// CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no xor-out.
static uint16_t crc16(const char *s, size_t n) {
  uint16_t crc = 0xFFFF;
  for (size_t i = 0; i < n; i++) {
    crc ^= (uint16_t)(uint8_t)s[i] << 8;
    for (uint8_t b = 0; b < 8; b++) {
      crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
    }
  }
  return crc;
}

// Frames `text` into `out` as "<text> *XXXX" (no newline).
static void frame(const char *text, char *out) {
  char head[MAX_LINE + 1];
  snprintf(head, sizeof head, "%s ", text);
  snprintf(out, MAX_LINE + 1, "%s*%04X", head, crc16(head, strlen(head)));
}

static void send(const char *framed) {
  Serial.print(framed);
  Serial.print('\n');
}

static void apply() {
  for (uint8_t i = 0; i < 3; i++) analogWrite(PINS[i], duty[i]);
}

static int light_index(const char *code) {
  for (uint8_t i = 0; i < 3; i++) {
    if (code && strcmp(code, CODES[i]) == 0) return i;
  }
  return -1;
}

// Executes tokens[1..n] and writes the framed reply into `reply`.
static void execute(uint16_t seq, char **tok, uint8_t n, char *reply) {
  char text[MAX_LINE + 1];
  const char *cmd = n > 1 ? tok[1] : "";
  if (strcmp(cmd, "HELLO") == 0 && n == 2) {
    snprintf(text, sizeof text, "%u OK HELLO %u %s %lu", seq, PROTOCOL, FIRMWARE, HEARTBEAT_MS);
  } else if (strcmp(cmd, "PING") == 0 && n == 2) {
    snprintf(text, sizeof text, "%u OK", seq);
  } else if (strcmp(cmd, "ALLOFF") == 0 && n == 2) {
    memset(duty, 0, sizeof duty);
    apply();
    snprintf(text, sizeof text, "%u OK", seq);
  } else if (strcmp(cmd, "OFF") == 0 && n == 3) {
    int l = light_index(tok[2]);
    if (l < 0) {
      snprintf(text, sizeof text, "%u ERR BADLIGHT", seq);
    } else {
      duty[l] = 0;
      apply();
      snprintf(text, sizeof text, "%u OK", seq);
    }
  } else if (strcmp(cmd, "ON") == 0 && n == 4) {
    int l = light_index(tok[2]);
    char *end;
    long level = strtol(tok[3], &end, 10);
    if (l < 0) {
      snprintf(text, sizeof text, "%u ERR BADLIGHT", seq);
    } else if (*end != '\0' || end == tok[3] || level < 0 || level > 255) {
      snprintf(text, sizeof text, "%u ERR BADLEVEL", seq);
    } else {
      duty[l] = (uint8_t)level;
      apply();
      snprintf(text, sizeof text, "%u OK", seq);
    }
  } else {
    snprintf(text, sizeof text, "%u ERR BADCMD", seq);
  }
  frame(text, reply);
}

static void handle_line(char *s) {
  char *star = strrchr(s, '*');
  if (!star || strlen(star + 1) != 4) return;  // corrupt: the host retries
  char *end;
  unsigned long got = strtoul(star + 1, &end, 16);
  if (*end != '\0' || got != crc16(s, (size_t)(star - s))) return;
  *star = '\0';
  char *tok[6];
  uint8_t n = 0;
  for (char *t = strtok(s, " "); t && n < 6; t = strtok(NULL, " ")) tok[n++] = t;
  if (n == 0) return;
  long seq = strtol(tok[0], &end, 10);
  if (*end != '\0' || seq < 0 || seq > 65535) {
    char reply[MAX_LINE + 1];
    frame("0 ERR BADSEQ", reply);
    send(reply);
    return;
  }
  last_request_ms = millis();
  heartbeat_armed = true;
  if (!(have_last && last_seq == (uint16_t)seq)) {
    execute((uint16_t)seq, tok, n, last_reply);
    last_seq = (uint16_t)seq;
    have_last = true;
  }
  send(last_reply);
}

void setup() {
  for (uint8_t i = 0; i < 3; i++) {
    pinMode(PINS[i], OUTPUT);
    analogWrite(PINS[i], 0);
  }
  Serial.begin(115200);
  char banner[MAX_LINE + 1];
  char text[MAX_LINE + 1];
  snprintf(text, sizeof text, "READY %u %s", PROTOCOL, FIRMWARE);
  frame(text, banner);
  send(banner);
}

void loop() {
  while (Serial.available() > 0) {
    char c = (char)Serial.read();
    if (c == '\r') continue;
    if (c == '\n') {
      line[line_len] = '\0';
      if (!line_overflow) handle_line(line);
      line_len = 0;
      line_overflow = false;
    } else if (line_len >= MAX_LINE) {
      line_overflow = true;
    } else {
      line[line_len++] = c;
    }
  }
  if (heartbeat_armed && millis() - last_request_ms > HEARTBEAT_MS) {
    memset(duty, 0, sizeof duty);
    apply();
    heartbeat_armed = false;
  }
}
