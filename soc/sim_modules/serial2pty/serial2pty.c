/* serial2pty: LiteX simulation module connecting the SoC's stream UART (the "serial" pads
 * of RS232PHYModel) to a new pseudo-terminal, so that a host program opens the simulated
 * board's UART like a USB-serial adapter.
 *
 * At start it opens a pty pair in raw mode and prints "serial2pty: /dev/pts/N" on stdout.
 * It keeps the pty's slave side open itself, so that output written before a client opens
 * it waits in the tty buffer instead of being lost.
 *
 * Flow control both ways, unlike LiteX's serial2tcp (which drops bytes with no client and
 * overruns its 2 KiB receive buffer when the host writes faster than the SoC reads):
 *   - SoC -> host: bytes go to `out`; when `out` is full (the pty does not take more),
 *     `source_ready` stays low and the SoC's UART waits;
 *   - host -> SoC: the pty is only read into the free part of `in`; `sink_valid` offers the
 *     head byte until the SoC takes it.
 * The pty is polled every POLL_CYCLES clock cycles.
 *
 * A line that keeps time: with "baud" set, the SoC -> host direction takes one byte per
 * 10 bit times of simulated time (8N1 at that baud rate on a clock of "clk_hz"), as a
 * real transmitter would: `source_ready` stays low while the line is busy, so the SoC's
 * transmit FIFO backs up and its firmware waits exactly as on a board. "rx_baud" paces the
 * host -> SoC direction the same way; 0 (the default) leaves it unpaced (a byte per clock
 * at most), so that a scene upload does not cost simulated minutes. With "rx_overrun" set
 * as well, the host -> SoC line is a board's: a byte that has arrived while the SoC's receive
 * FIFO is full is lost (counted, and printed with the speed reports), as the RS232 PHY of a
 * board, which has no flow control, loses it.
 *
 * It counts the clock cycles it sees and prints the simulation's speed, simulated cycles per
 * wall-clock second, every REPORT_S seconds and when it closes:
 *   "serial2pty: speed <cycles> cycles in <s> s: <rate> cycles/s"
 *
 * Arguments (sim_config.js, all optional): {"link": "/path"} also makes a symlink to the
 * pty; "clk_hz", "baud", "rx_baud", "rx_overrun" as above (numbers as strings or integers).
 */
/* posix_openpt, grantpt, unlockpt, ptsname, cfmakeraw. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <json-c/json.h>

#include "error.h"
#include "modules.h"

#define BUF_SIZE 4096
#define POLL_CYCLES 1024
#define REPORT_S 10.0
/* The wall clock is read once per this many cycles (a syscall per cycle would be the cost). */
#define CLOCK_CHECK_CYCLES (1u << 20)

struct session_s {
  /* Pads: tx = SoC -> host (the PHY's sink side), rx = host -> SoC. */
  char *tx;
  char *tx_valid;
  char *tx_ready;
  char *rx;
  char *rx_valid;
  char *rx_ready;
  char *sys_clk;
  clk_edge_state_t edge;
  int master;
  int slave_hold;
  uint8_t in[BUF_SIZE]; /* from the host, not yet taken by the SoC */
  size_t in_head, in_len;
  uint8_t out[BUF_SIZE]; /* from the SoC, not yet written to the pty */
  size_t out_len;
  uint64_t cycle, next_poll;
  /* Pacing: a byte takes 10 * clk_hz / baud cycles. Kept exact as a rational: the line is
   * free again once cycle * baud >= *_free_at (units of cycles x baud). */
  uint64_t clk_hz, tx_baud, rx_baud, rx_overrun;
  /* Bytes the host sent that arrived while the SoC's receive FIFO was full (rx_overrun). */
  uint64_t rx_lost;
  uint64_t tx_free_at, rx_free_at;
  /* Speed report. */
  double wall_start, wall_last;
  uint64_t cycle_last;
};

static double wall_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static void report_speed(struct session_s *s, double now, const char *what) {
  double span = now - s->wall_last;
  double total = now - s->wall_start;
  printf("serial2pty: speed %llu cycles in %.1f s: %.0f cycles/s (%s; %.0f cycles/s since start)\n",
         (unsigned long long)(s->cycle - s->cycle_last), span, span > 0 ? (double)(s->cycle - s->cycle_last) / span : 0.0,
         what, total > 0 ? (double)s->cycle / total : 0.0);
  if (s->rx_overrun)
    printf("serial2pty: overrun: %llu bytes from the host lost (the SoC's receive FIFO was full)\n",
           (unsigned long long)s->rx_lost);
  fflush(stdout);
  s->wall_last = now;
  s->cycle_last = s->cycle;
}

static int serial2pty_start(void *base) {
  (void)base;
  return RC_OK;
}

static char *optional_arg(const char *args, const char *key) {
  json_object *root, *obj;
  char *value = NULL;
  if (!args)
    return NULL;
  root = json_tokener_parse(args);
  if (root && json_object_object_get_ex(root, key, &obj))
    value = strdup(json_object_get_string(obj));
  if (root)
    json_object_put(root);
  return value;
}

static int open_pty(struct session_s *s, const char *link) {
  struct termios t;
  const char *name;

  s->master = posix_openpt(O_RDWR | O_NOCTTY);
  if (s->master < 0 || grantpt(s->master) != 0 || unlockpt(s->master) != 0) {
    eprintf("serial2pty: cannot open a pseudo-terminal: %s\n", strerror(errno));
    return RC_ERROR;
  }
  name = ptsname(s->master);
  if (!name) {
    eprintf("serial2pty: ptsname: %s\n", strerror(errno));
    return RC_ERROR;
  }
  s->slave_hold = open(name, O_RDWR | O_NOCTTY);
  if (s->slave_hold < 0 || tcgetattr(s->slave_hold, &t) != 0) {
    eprintf("serial2pty: opening %s: %s\n", name, strerror(errno));
    return RC_ERROR;
  }
  /* Raw until a client configures it: no echo, no CR/LF translation of the binary link. */
  cfmakeraw(&t);
  tcsetattr(s->slave_hold, TCSANOW, &t);
  fcntl(s->master, F_SETFL, fcntl(s->master, F_GETFL) | O_NONBLOCK);
  if (link) {
    unlink(link);
    if (symlink(name, link) != 0) {
      eprintf("serial2pty: symlink %s -> %s: %s\n", link, name, strerror(errno));
      return RC_ERROR;
    }
  }
  printf("serial2pty: %s\n", name);
  fflush(stdout);
  return RC_OK;
}

static uint64_t number_arg(const char *args, const char *key) {
  char *v = optional_arg(args, key);
  uint64_t n = v ? strtoull(v, NULL, 10) : 0;
  free(v);
  return n;
}

static int serial2pty_new(void **sess, char *args) {
  struct session_s *s;
  char *link;
  int ret;

  if (!sess)
    return RC_INVARG;
  s = calloc(1, sizeof(*s));
  if (!s)
    return RC_NOENMEM;
  s->master = s->slave_hold = -1;
  link = optional_arg(args, "link");
  s->clk_hz = number_arg(args, "clk_hz");
  s->tx_baud = number_arg(args, "baud");
  s->rx_baud = number_arg(args, "rx_baud");
  s->rx_overrun = number_arg(args, "rx_overrun");
  if (s->rx_overrun && !s->rx_baud) {
    eprintf("serial2pty: \"rx_overrun\" needs \"rx_baud\"\n");
    free(link);
    *sess = s;
    return RC_ERROR;
  }
  if ((s->tx_baud || s->rx_baud) && !s->clk_hz) {
    eprintf("serial2pty: \"baud\" needs \"clk_hz\"\n");
    free(link);
    *sess = s;
    return RC_ERROR;
  }
  ret = open_pty(s, link);
  free(link);
  if (ret == RC_OK) {
    printf("serial2pty: line SoC->host %llu baud, host->SoC %llu baud (0: unpaced), clock %llu Hz\n",
           (unsigned long long)s->tx_baud, (unsigned long long)s->rx_baud, (unsigned long long)s->clk_hz);
    fflush(stdout);
  }
  s->wall_start = s->wall_last = wall_now();
  *sess = s;
  return ret;
}

static void pads_get(struct pad_s *pads, const char *name, char **signal) {
  for (int i = 0; pads[i].name; i++) {
    if (!strcmp(pads[i].name, name)) {
      *signal = (char *)pads[i].signal;
      return;
    }
  }
}

static int serial2pty_add_pads(void *sess, struct pad_list_s *plist) {
  struct session_s *s = sess;
  if (!s || !plist)
    return RC_INVARG;
  if (!strcmp(plist->name, "serial")) {
    pads_get(plist->pads, "source_data", &s->tx);
    pads_get(plist->pads, "source_valid", &s->tx_valid);
    pads_get(plist->pads, "source_ready", &s->tx_ready);
    pads_get(plist->pads, "sink_data", &s->rx);
    pads_get(plist->pads, "sink_valid", &s->rx_valid);
    pads_get(plist->pads, "sink_ready", &s->rx_ready);
  }
  if (!strcmp(plist->name, "sys_clk"))
    pads_get(plist->pads, "sys_clk", &s->sys_clk);
  return RC_OK;
}

/* Moves bytes between the buffers and the pty without blocking. */
static void poll_pty(struct session_s *s) {
  if (s->out_len) {
    ssize_t n = write(s->master, s->out, s->out_len);
    if (n > 0) {
      memmove(s->out, s->out + n, s->out_len - (size_t)n);
      s->out_len -= (size_t)n;
    }
  }
  if (s->in_len == 0)
    s->in_head = 0;
  if (s->in_head + s->in_len < BUF_SIZE) {
    ssize_t n = read(s->master, s->in + s->in_head + s->in_len, BUF_SIZE - s->in_head - s->in_len);
    if (n > 0)
      s->in_len += (size_t)n;
  }
}

static int serial2pty_tick(void *sess, uint64_t time_ps) {
  struct session_s *s = sess;
  (void)time_ps;
  if (!clk_pos_edge(&s->edge, *s->sys_clk))
    return RC_OK;
  s->cycle++;

  /* The pads were just updated by this edge; what we set now holds at the next one (the
   * UART's valid and ready do not depend on ours combinationally: FIFO flags). */
  if (s->cycle >= s->next_poll) {
    poll_pty(s);
    s->next_poll = s->cycle + POLL_CYCLES;
  }

  if ((s->cycle & (CLOCK_CHECK_CYCLES - 1)) == 0) {
    double now = wall_now();
    if (now - s->wall_last >= REPORT_S)
      report_speed(s, now, "running");
  }

  /* SoC -> host: accept the byte on offer at the next edge if there is room for it and the
   * line has finished the previous byte. */
  *s->tx_ready = s->out_len < BUF_SIZE && (!s->tx_baud || s->cycle * s->tx_baud >= s->tx_free_at);
  if (*s->tx_valid && *s->tx_ready) {
    s->out[s->out_len++] = (uint8_t)*s->tx;
    /* Back to back, a byte starts when the last one ends (no rounding drift). */
    if (s->tx_baud)
      s->tx_free_at = (s->cycle * s->tx_baud > s->tx_free_at ? s->cycle * s->tx_baud : s->tx_free_at) + 10 * s->clk_hz;
  }

  /* Host -> SoC: offer the head byte once the line has delivered it; it is taken at the
   * next edge when ready is high. */
  *s->rx_valid = 0;
  if (s->in_len && (!s->rx_baud || s->cycle * s->rx_baud >= s->rx_free_at)) {
    *s->rx = (char)s->in[s->in_head];
    *s->rx_valid = 1;
    if (!*s->rx_ready && s->rx_overrun) {
      /* The byte has arrived and the FIFO has no room: a board's PHY drops it. */
      *s->rx_valid = 0;
      s->rx_lost++;
    }
    if (*s->rx_ready || s->rx_overrun) {
      s->in_head++;
      s->in_len--;
      if (s->rx_baud)
        s->rx_free_at =
            (s->cycle * s->rx_baud > s->rx_free_at ? s->cycle * s->rx_baud : s->rx_free_at) + 10 * s->clk_hz;
    }
  }
  return RC_OK;
}

static int serial2pty_close(void *sess) {
  struct session_s *s = sess;
  if (!s)
    return RC_OK;
  report_speed(s, wall_now(), "at exit");
  if (s->master >= 0) {
    /* Deliver what the SoC sent last (best effort: the pty may be full). */
    ssize_t n = s->out_len ? write(s->master, s->out, s->out_len) : 0;
    (void)n;
    close(s->master);
  }
  if (s->slave_hold >= 0)
    close(s->slave_hold);
  free(s);
  return RC_OK;
}

static struct ext_module_s ext_mod = {
    "serial2pty", serial2pty_start, serial2pty_new, serial2pty_add_pads, serial2pty_close, serial2pty_tick,
};

int litex_sim_ext_module_init(int (*register_module)(struct ext_module_s *)) {
  return register_module(&ext_mod);
}
