// uml-xstate-shim: starts Debian's user-mode-linux kernel (6.1) on a host whose XSAVE area is
// larger than the one UML knows (AVX-512, AMX: 11008 bytes where UML passes 832), which UML
// cannot run otherwise: every PTRACE_SETREGSET of NT_X86_XSTATE with its buffer fails with
// EFAULT and the guest's init dies at once ("userspace - ptrace set fp regs failed, errno =
// 14"). scripts/vcan-run compiles and uses it; nothing else does.
//
//   uml-xstate-shim --needed           exit 0 when this host needs the shim, 1 when not
//   uml-xstate-shim UML [ARGS...]      exec UML with PTRACE_{GET,SET}REGSET of NT_X86_XSTATE
//                                      refused (EIO) by a seccomp filter
//
// Refused, UML finds no XSAVE support and saves and restores registers with
// PTRACE_{GET,SET}FPREGS: the x87 and SSE state (FXSAVE, 512 bytes). UML runs one host process
// per guest address space, whose AVX and later state the host kernel keeps; what is not kept
// is that state between threads of one guest process (they share a host process) and around
// signal handlers. So threaded guest programs must not use AVX: vcan-run tells glibc
// (GLIBC_TUNABLES) to take its SSE2 functions, and the project builds for baseline x86-64.
// Libraries that pick AVX from CPUID themselves (OpenSSL, OpenBLAS, ...) are not covered: the
// vm tests' programs load libcrypto through the DDS libraries but call none of it (no DDS
// security), and load no other.
#include <cpuid.h>
#include <errno.h>
#include <linux/audit.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

enum {
  kNtX86Xstate = 0x202,     // NT_X86_XSTATE (elf.h)
  kGetRegset = 0x4204,      // PTRACE_GETREGSET
  kSetRegset = 0x4205,      // PTRACE_SETREGSET
  kUmlXstateBytes = 832,    // UML 6.1's buffer: struct _xstate (FXSAVE + header + YMM high halves)
};

// The XSAVE area of the features the kernel enabled (XCR0), as CPUID leaf 0xD reports it.
static unsigned xsave_bytes(void) {
  unsigned eax, ebx, ecx, edx;
  if (!__get_cpuid_count(0xd, 0, &eax, &ebx, &ecx, &edx)) return 0;
  return ebx;
}

int main(int argc, char** argv) {
  if (argc == 2 && strcmp(argv[1], "--needed") == 0) {
    const unsigned bytes = xsave_bytes();
    printf("XSAVE area %u bytes, user-mode-linux's %d\n", bytes, kUmlXstateBytes);
    return bytes > kUmlXstateBytes ? 0 : 1;
  }
  if (argc < 2) {
    fprintf(stderr, "usage: uml-xstate-shim --needed | UML [ARGS...]\n");
    return 2;
  }
  struct sock_filter filter[] = {
      BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, arch)),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, AUDIT_ARCH_X86_64, 1, 0),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
      BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, nr)),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, __NR_ptrace, 1, 0),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
      // ptrace(request, pid, addr, data): request and addr, low 32 bits (both fit).
      BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, args[0])),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, kGetRegset, 2, 0),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, kSetRegset, 1, 0),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
      BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, args[2])),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, kNtX86Xstate, 0, 1),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ERRNO | EIO),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
  };
  struct sock_fprog program = {(unsigned short)(sizeof filter / sizeof filter[0]), filter};
  if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 || prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, &program) != 0) {
    fprintf(stderr, "uml-xstate-shim: cannot install the seccomp filter: %s\n", strerror(errno));
    return 127;
  }
  execv(argv[1], argv + 1);
  fprintf(stderr, "uml-xstate-shim: cannot run %s: %s\n", argv[1], strerror(errno));
  return 127;
}
