/* Keeps a ROS node's servers on the loopback interface (LD_PRELOAD; env.sh sets it up).

   ROS_IP=127.0.0.1 puts the master, every rospy server and roscpp's TCPROS server on loopback, but roscpp's XML-RPC
   server (xmlrpcpp) binds every interface whatever ROS_IP says: anyone on the network could then call the node's
   API (publisherUpdate, shutdown, ...). With LANDING_ROS_LOOPBACK=1 this library turns a TCP bind to "any
   address" (0.0.0.0 or ::) into a bind to loopback, in ROS nodes only: processes started with a __name:= argument,
   as roslaunch and rosrun ... __name:= start them (Ray, browsers and other servers of the shell are left alone).
   Unset or 0 (env.sh does so when ROS_IP or ROS_HOSTNAME is set, see the README): nothing changes. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/types.h>

typedef int (*bind_function)(int, const struct sockaddr*, socklen_t);

/* 1 when this process is a ROS node (a __name:= argument) and LANDING_ROS_LOOPBACK=1, else 0; decided once. */
static int loopback_only(void) {
  static int decided = -1;
  if (decided >= 0) return decided;
  decided = 0;
  const char* on = getenv("LANDING_ROS_LOOPBACK");
  if (on == NULL || strcmp(on, "1") != 0) return decided;
  FILE* cmdline = fopen("/proc/self/cmdline", "rb");
  if (cmdline == NULL) return decided;
  char buffer[8192];
  size_t length = fread(buffer, 1, sizeof(buffer) - 1, cmdline);
  fclose(cmdline);
  buffer[length] = '\0';
  for (size_t start = 0; start < length; start += strlen(buffer + start) + 1) {
    if (strncmp(buffer + start, "__name:=", 8) == 0) {
      decided = 1;
      break;
    }
  }
  return decided;
}

int bind(int fd, const struct sockaddr* address, socklen_t length) {
  static bind_function real_bind = NULL;
  if (real_bind == NULL) real_bind = (bind_function)dlsym(RTLD_NEXT, "bind");
  int type = 0;
  socklen_t type_length = sizeof(type);
  if (address != NULL && loopback_only() && getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &type_length) == 0 &&
      type == SOCK_STREAM) {
    if (address->sa_family == AF_INET && length >= sizeof(struct sockaddr_in)) {
      struct sockaddr_in loopback = *(const struct sockaddr_in*)address;
      if (loopback.sin_addr.s_addr == htonl(INADDR_ANY)) {
        loopback.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        return real_bind(fd, (const struct sockaddr*)&loopback, sizeof(loopback));
      }
    } else if (address->sa_family == AF_INET6 && length >= sizeof(struct sockaddr_in6)) {
      struct sockaddr_in6 loopback = *(const struct sockaddr_in6*)address;
      if (IN6_IS_ADDR_UNSPECIFIED(&loopback.sin6_addr)) {
        loopback.sin6_addr = in6addr_loopback;
        return real_bind(fd, (const struct sockaddr*)&loopback, sizeof(loopback));
      }
    }
  }
  return real_bind(fd, address, length);
}
