// can_raw_smoke: proves the kernel CAN stack inside the qemu VM before any project code runs.
// Two CAN_RAW sockets on one interface (default vcan0, or $DGW_CAN_IFACE, or argv[1]):
//   1. A sends a standard 11-bit frame, B receives it byte-exact;
//   2. B sends an extended 29-bit frame, A receives it byte-exact;
//   3. B filters on one standard ID: a non-matching frame is not delivered, a matching one is;
//   4. a remote (RTR) frame keeps its flag.
// Every receive waits at most 2 s (poll), so the program never hangs. Exit 0 = all passed.
// Built statically by run.sh (`cc -static`), so it needs no libraries inside the VM.
#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

static int failures;

#define CHECK(cond, ...)                                         \
  do {                                                           \
    if (!(cond)) {                                               \
      fprintf(stderr, "can_raw_smoke: FAIL %s:%d: ", __FILE__, __LINE__); \
      fprintf(stderr, __VA_ARGS__);                              \
      fputc('\n', stderr);                                       \
      failures++;                                                \
      return -1;                                                 \
    }                                                            \
  } while (0)

static int open_raw(const char *iface) {
  int s = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (s < 0) {
    fprintf(stderr, "can_raw_smoke: socket(PF_CAN, SOCK_RAW, CAN_RAW): %s\n", strerror(errno));
    return -1;
  }
  struct ifreq ifr;
  memset(&ifr, 0, sizeof ifr);
  snprintf(ifr.ifr_name, sizeof ifr.ifr_name, "%s", iface);
  if (ioctl(s, SIOCGIFINDEX, &ifr) < 0) {
    fprintf(stderr, "can_raw_smoke: interface %s: %s\n", iface, strerror(errno));
    close(s);
    return -1;
  }
  struct sockaddr_can addr;
  memset(&addr, 0, sizeof addr);
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (bind(s, (struct sockaddr *)&addr, sizeof addr) < 0) {
    fprintf(stderr, "can_raw_smoke: bind %s: %s\n", iface, strerror(errno));
    close(s);
    return -1;
  }
  return s;
}

// Returns 1 and fills *f if a frame arrives within timeout_ms, 0 on timeout, -1 on error.
static int recv_frame(int s, struct can_frame *f, int timeout_ms) {
  struct pollfd p = {.fd = s, .events = POLLIN};
  int r = poll(&p, 1, timeout_ms);
  if (r <= 0) return r < 0 ? -1 : 0;
  ssize_t n = read(s, f, sizeof *f);
  if (n != (ssize_t)sizeof *f) return -1;
  return 1;
}

static int send_frame(int s, const struct can_frame *f) {
  return write(s, f, sizeof *f) == (ssize_t)sizeof *f ? 0 : -1;
}

static int same(const struct can_frame *a, const struct can_frame *b) {
  return a->can_id == b->can_id && a->len == b->len && memcmp(a->data, b->data, a->len) == 0;
}

static int exchange(int tx, int rx, const struct can_frame *out, const char *what) {
  CHECK(send_frame(tx, out) == 0, "%s: write: %s", what, strerror(errno));
  struct can_frame in;
  memset(&in, 0, sizeof in);
  int r = recv_frame(rx, &in, 2000);
  CHECK(r == 1, "%s: %s", what, r == 0 ? "nothing received within 2 s" : strerror(errno));
  CHECK(same(out, &in), "%s: received id %08x len %u, sent id %08x len %u", what,
        (unsigned)in.can_id, in.len, (unsigned)out->can_id, out->len);
  printf("can_raw_smoke: ok   %s (id %08x, %u bytes)\n", what, (unsigned)in.can_id, in.len);
  return 0;
}

static int test_filter(int a, int b) {
  struct can_filter flt = {.can_id = 0x321, .can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG};
  CHECK(setsockopt(b, SOL_CAN_RAW, CAN_RAW_FILTER, &flt, sizeof flt) == 0, "CAN_RAW_FILTER: %s",
        strerror(errno));
  struct can_frame other = {.can_id = 0x322, .len = 1, .data = {0xAA}};
  struct can_frame match = {.can_id = 0x321, .len = 2, .data = {0x55, 0x66}};
  CHECK(send_frame(a, &other) == 0, "filter: write: %s", strerror(errno));
  CHECK(send_frame(a, &match) == 0, "filter: write: %s", strerror(errno));
  struct can_frame in;
  int r = recv_frame(b, &in, 2000);
  CHECK(r == 1, "filter: matching frame not received");
  CHECK(same(&in, &match), "filter: got id %03x, expected only 321", (unsigned)in.can_id);
  r = recv_frame(b, &in, 200);
  CHECK(r == 0, "filter: a second frame (id %03x) passed the filter", (unsigned)in.can_id);
  printf("can_raw_smoke: ok   filter (321 delivered, 322 dropped)\n");
  return 0;
}

int main(int argc, char **argv) {
  const char *iface = argc > 1 ? argv[1] : getenv("DGW_CAN_IFACE");
  if (iface == NULL || *iface == '\0') iface = "vcan0";
  setvbuf(stdout, NULL, _IOLBF, 0);
  int a = open_raw(iface), b = open_raw(iface);
  if (a < 0 || b < 0) return 2;

  struct can_frame std_frame = {.can_id = 0x123, .len = 8,
                                .data = {0xDE, 0xAD, 0xBE, 0xEF, 0x01, 0x02, 0x03, 0x04}};
  struct can_frame ext_frame = {.can_id = 0x1ABCDE0F | CAN_EFF_FLAG, .len = 3,
                                .data = {0x00, 0x4B, 0x03}};
  struct can_frame rtr_frame = {.can_id = 0x7E5 | CAN_RTR_FLAG, .len = 0};
  exchange(a, b, &std_frame, "standard frame A->B");
  exchange(b, a, &ext_frame, "extended frame B->A");
  exchange(a, b, &rtr_frame, "remote frame A->B");
  test_filter(a, b);

  close(a);
  close(b);
  printf("can_raw_smoke: %s on %s\n", failures ? "FAILED" : "all passed", iface);
  return failures ? 1 : 0;
}
